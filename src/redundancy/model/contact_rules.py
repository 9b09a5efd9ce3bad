"""Which body pairs MuJoCo tests for contact: on the whole robot, and on the arm held in it.

`bodies_filtered` is MuJoCo's own body-pair filter; `keep_contact_rules` carries the whole
robot's filter over to the arm's model, where welding the held joints would change it.
"""

from __future__ import annotations

import mujoco

from .names import display_names


def moved_bodies(model: mujoco.MjModel, arm_joints: set[int]) -> set[int]:
    """Bodies an arm joint moves: the bodies of the arm joints and everything below them."""
    out: set[int] = set()
    for b in range(1, model.nbody):
        c = b
        while c != 0:
            lo, n = model.body_jntadr[c], model.body_jntnum[c]
            if any(j in arm_joints for j in range(lo, lo + n)):
                out.add(b)
                break
            c = int(model.body_parentid[c])
    return out


def bodies_filtered(model: mujoco.MjModel, b1: int, b2: int) -> bool:
    """MuJoCo's body-pair filter (filterBodyPair in engine_collision_driver.c).

    Bodies welded together (same ``body_weldid``, which includes a body and itself) never
    collide. With ``filterparent`` on (the default), a body does not collide with its parent,
    where both are taken as weld groups: the parent of a weld group is the weld group of the
    parent of its root body. The world exception: the parent filter only applies when
    neither weld group is the world's, so a body attached to the world by a joint does
    collide with geoms welded to the world (a floor, a base plate).
    """
    w1, w2 = int(model.body_weldid[b1]), int(model.body_weldid[b2])
    if w1 == w2:
        return True
    if model.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_FILTERPARENT:
        return False
    if w1 == 0 or w2 == 0:
        return False
    pw1 = int(model.body_weldid[model.body_parentid[w1]])
    pw2 = int(model.body_weldid[model.body_parentid[w2]])
    return w1 == pw2 or w2 == pw1


def arm_welds(model: mujoco.MjModel, arm_joints: set[int]) -> list[int]:
    """Each body's weld group once the held joints are welded.

    A body's nearest ancestor (or itself) carrying an arm joint, 0 (the world) when none
    does. Two bodies of one group never move relative to each other, whatever the arm does.
    """
    welds = [0] * model.nbody
    for b in range(1, model.nbody):  # parents come before children in MuJoCo's body order
        lo, n = int(model.body_jntadr[b]), int(model.body_jntnum[b])
        arm = any(j in arm_joints for j in range(lo, lo + n))
        welds[b] = b if arm else welds[int(model.body_parentid[b])]
    return welds


def keep_contact_rules(
    spec: mujoco.MjSpec, full: mujoco.MjModel, arm: set[int], spec_bodies: list
) -> None:
    """The whole robot's contact filter in the arm's model (MuJoCo then tests the same pairs).

    Welding the held joints merges weld groups, and MuJoCo's parent filter works on weld
    groups: on the arm's model it would both drop pairs the robot tests (a held finger welded
    into the hand becomes a child of the forearm) and test pairs the robot never does (a
    held free pelvis welded to the world loses its parent rule with the torso, by the world
    exception). So the parent filter is turned off in the arm's model and every body pair the
    robot's own parent filter drops becomes an ``<exclude>``; together with the weld rule, the
    bitmasks and the file's excludes (an SRDF's among them), the arm's model then tests
    exactly the robot's pairs whose distance the arm can change. The file's explicit pairs
    that the arm cannot change (both geoms in one weld group) are dropped with them.
    """
    welds = arm_welds(full, arm)
    names = display_names(full, mujoco.mjtObj.mjOBJ_BODY)
    colliding = [b for b in range(full.nbody) if full.body_contype[b] or full.body_conaffinity[b]]
    excluded = {(int(s) >> 16, int(s) & 0xFFFF) for s in full.exclude_signature}
    for i, b1 in enumerate(colliding):
        for b2 in colliding[i + 1 :]:
            if welds[b1] == welds[b2] or (b1, b2) in excluded:
                continue
            if not (
                full.body_contype[b1] & full.body_conaffinity[b2]
                or full.body_contype[b2] & full.body_conaffinity[b1]
            ):
                continue
            if bodies_filtered(full, b1, b2):
                for b in (b1, b2):  # an exclude names its bodies
                    if not spec_bodies[b].name:
                        spec_bodies[b].name = names[b]
                spec.add_exclude(bodyname1=spec_bodies[b1].name, bodyname2=spec_bodies[b2].name)
    spec.option.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_FILTERPARENT)
    geom = mujoco.mjtObj.mjOBJ_GEOM
    for pair in list(spec.pairs):  # by name: the compiler sorts the pairs
        g1 = mujoco.mj_name2id(full, geom, pair.geomname1)
        g2 = mujoco.mj_name2id(full, geom, pair.geomname2)
        if welds[int(full.geom_bodyid[g1])] == welds[int(full.geom_bodyid[g2])]:
            spec.delete(pair)
