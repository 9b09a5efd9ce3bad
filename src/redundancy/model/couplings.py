"""Couplings in the robot's file: joint equalities its held joints follow, and what reaches the arm.

A held joint coupled to another (a URDF ``<mimic>``, an MJCF joint equality) follows its leader
at rest (`follow_couplings`). When the held joints are welded, every equality, tendon and
actuator is either set aside (it acts on held joints or bodies only) or refused (it reaches an
arm joint or a body the arm moves): `check_couplings`; `delete_couplings` then removes what was
set aside from the robot's spec.
"""

from __future__ import annotations

from collections.abc import Sequence, Set

import mujoco

from ..errors import ParameterError, UnsupportedFeatureError
from .actuators import transmission_refusal
from .names import display_names
from .selection import Array, SetAside


def follow_couplings(
    model: mujoco.MjModel, qpos: Array, arm: set[int], given: Set[int] = frozenset()
) -> None:
    """Held joints coupled to others (a URDF ``<mimic>``, an MJCF joint equality) follow them.

    MuJoCo's joint equality holds ``q1 - ref1 = c0 + c1 x + c2 x^2 + c3 x^3 + c4 x^4`` with
    ``x = q2 - ref2`` (``x = 0`` without a second joint); a URDF mimic is ``c0 = offset``,
    ``c1 = multiplier``. Each held follower (joint1) whose leader is held too is set from its
    leader, in ``qpos`` (in place), a follower of a follower after its leader. Couplings that
    reach an arm joint are left to `reduce_mujoco` (refused there).

    Args:
        model: MuJoCo's compiled model of the whole robot.
        qpos: The whole robot's configuration, edited in place.
        arm: Arm joint ids.
        given: Joints whose values the user set: a follower among them whose value
            contradicts its coupling is refused.

    Raises:
        ParameterError: A value given for a follower that its coupling does not give.
    """
    eqs = [
        k
        for k in range(model.neq)
        if model.eq_type[k] == mujoco.mjtEq.mjEQ_JOINT
        and model.eq_active0[k]
        and int(model.eq_obj1id[k]) not in arm
        and int(model.eq_obj2id[k]) not in arm
    ]
    names = display_names(model, mujoco.mjtObj.mjOBJ_JOINT)
    for _ in range(len(eqs) + 1):  # a chain of n couplings settles in n passes
        moved = False
        for k in eqs:
            j1, j2 = int(model.eq_obj1id[k]), int(model.eq_obj2id[k])
            a1 = int(model.jnt_qposadr[j1])
            leader = float(qpos[model.jnt_qposadr[j2]]) if j2 >= 0 else 0.0
            value = coupling_value(model, k, leader)
            if qpos[a1] == value:
                continue
            if j1 in given and abs(qpos[a1] - value) > 1e-9 * max(1.0, abs(value)):
                leader = names[j2] if j2 >= 0 else ""
                rule = coupling_text(model, k, names)
                raise ParameterError(
                    f"rest[{names[j1]!r}]",
                    float(qpos[a1]),
                    f"{value:.6g}, the value its coupling to joint {leader!r} gives ({rule}); "
                    f"set {leader!r} and {names[j1]!r} follows"
                    if leader
                    else f"{value:.6g}, the value its equality fixes ({rule})",
                )
            qpos[a1] = value
            moved = True
        if not moved:
            return


def coupling_value(model: mujoco.MjModel, k: int, leader: float) -> float:
    """The value joint equality ``k`` gives its follower (joint1) [rad or m].

    ``qpos0_1 + c0 + c1 x + ... + c4 x^4`` with ``x = leader - qpos0_2`` (``x = 0`` without a
    second joint, whose ``leader`` is then ignored).

    Args:
        model: MuJoCo's compiled model.
        k: The equality's id (``mjEQ_JOINT``).
        leader: The leader's (joint2's) value [rad or m].
    """
    j1, j2 = int(model.eq_obj1id[k]), int(model.eq_obj2id[k])
    x = 0.0
    if j2 >= 0:
        x = float(leader - model.qpos0[model.jnt_qposadr[j2]])
    c = model.eq_data[k][:5]
    return float(model.qpos0[model.jnt_qposadr[j1]] + sum(c[i] * x**i for i in range(5)))


def coupling_text(model: mujoco.MjModel, k: int, names: Sequence[str]) -> str:
    """``fb = 0.6 - 1 fa``: joint equality ``k`` as the file's joints see it."""

    def shifted(j: int) -> str:
        ref = float(model.qpos0[model.jnt_qposadr[j]])
        if ref == 0:
            return names[j]
        return f"({names[j]} - {ref:.6g})" if ref > 0 else f"({names[j]} + {-ref:.6g})"

    j1, j2 = int(model.eq_obj1id[k]), int(model.eq_obj2id[k])
    x = shifted(j2) if j2 >= 0 else "0"
    terms = []
    for i, c in enumerate(model.eq_data[k][:5]):
        if c == 0 or (i and j2 < 0):
            continue
        mono = "" if i == 0 else f" {x}" if i == 1 else f" {x}^{i}"
        terms.append(f"{'-' if c < 0 else '+'} {abs(c):.6g}{mono}")
    rhs = " ".join(terms).removeprefix("+ ") or "0"
    if rhs.startswith("- "):
        rhs = "-" + rhs[2:]
    return f"{shifted(j1)} = {rhs}"


#: Why an actuator is set aside that drives a coupled arm's chain through a fixed tendon (the
#: audit notes that its torque is not judged).
TENDON_ON_CHAIN = "pulls a fixed tendon over the arm's coupled joints"


def check_couplings(
    full: mujoco.MjModel,
    arm: set[int],
    moved: set[int],
    out: list[SetAside],
    coupled: Set[int] = frozenset(),
) -> None:
    """Set aside couplings among held joints; refuse those that reach an arm joint.

    Args:
        full: MuJoCo's compiled model of the whole robot.
        arm: Arm joint ids (every joint the arm moves).
        moved: Bodies an arm joint moves.
        out: What was set aside, appended to (equalities, then tendons, then actuators).
        coupled: Equalities that couple the arm's joints (`redundancy.model.coupled_chain`):
            served in the arm's independent coordinates, set aside from the engines'
            models; with any, a fixed tendon over the arm's joints alone is set aside too
            (what an actuator pulls: no tendon force is in J, M or gravity).

    Raises:
        UnsupportedFeatureError: A coupling (equality, tendon, actuator) that reaches an arm
            joint or a body the arm moves.
    """
    jnames = display_names(full, mujoco.mjtObj.mjOBJ_JOINT)
    bnames = display_names(full, mujoco.mjtObj.mjOBJ_BODY)
    for k in range(full.neq):
        if k in coupled:
            out.append(_coupling(full, k, jnames))
            continue
        out.append(_equality(full, k, arm, moved, jnames, bnames))
    for t in range(full.ntendon):
        if coupled and _fixed_over(full, t, arm):
            name = mujoco.mj_id2name(full, mujoco.mjtObj.mjOBJ_TENDON, t) or f"tendon {t}"
            out.append(
                SetAside(
                    "tendon",
                    name,
                    "a fixed tendon over the arm's coupled joints (what an actuator pulls): "
                    "no tendon force is in J, M or gravity",
                )
            )
            continue
        out.append(_tendon(full, t, arm, moved, jnames, bnames))
    for u in range(full.nu):
        aside = _actuator(full, u, arm, moved, jnames)
        if aside is not None:
            out.append(aside)


def _coupling(full: mujoco.MjModel, k: int, jnames: Sequence[str]) -> SetAside:
    """Equality ``k`` that couples the arm's joints: served through the coupling map."""
    name = mujoco.mj_id2name(full, mujoco.mjtObj.mjOBJ_EQUALITY, k)
    if full.eq_type[k] == mujoco.mjtEq.mjEQ_JOINT:
        a, b = int(full.eq_obj1id[k]), int(full.eq_obj2id[k])
        shown = name or " = ".join(jnames[j] for j in (a, b) if j >= 0)
        return SetAside(
            "joint equality",
            shown,
            f"couples the arm's joints ({coupling_text(full, k, jnames)}): the arm's "
            "coordinates are its independent joints, the follower moves with them "
            "(arm.followers)",
            reaches_arm=True,
        )
    kind = "weld" if full.eq_type[k] == mujoco.mjtEq.mjEQ_WELD else "connect"
    return SetAside(
        "equality constraint",
        name or f"equality {k}",
        f"a {kind} that closes a loop of the arm's joints: the dependent joints are "
        "solved to close it at every pose (arm.followers)",
        reaches_arm=True,
    )


def _fixed_over(full: mujoco.MjModel, t: int, arm: set[int]) -> bool:
    """True when tendon ``t`` is a fixed tendon whose joints are all arm joints."""
    lo, n = int(full.tendon_adr[t]), int(full.tendon_num[t])
    wraps = range(lo, lo + n)
    return n > 0 and all(
        full.wrap_type[w] == mujoco.mjtWrap.mjWRAP_JOINT and int(full.wrap_objid[w]) in arm
        for w in wraps
    )


def _equality(
    full: mujoco.MjModel,
    k: int,
    arm: set[int],
    moved: set[int],
    jnames: Sequence[str],
    bnames: Sequence[str],
) -> SetAside:
    """Equality constraint ``k`` set aside, or refused when it reaches the arm."""
    name = mujoco.mj_id2name(full, mujoco.mjtObj.mjOBJ_EQUALITY, k) or f"equality {k}"
    kind = mujoco.mjtEq(full.eq_type[k])
    a, b = int(full.eq_obj1id[k]), int(full.eq_obj2id[k])
    if kind == mujoco.mjtEq.mjEQ_JOINT:
        return _joint_equality(full, k, arm, jnames)
    if kind == mujoco.mjtEq.mjEQ_TENDON:
        return SetAside("equality constraint", name, "couples tendons (checked below)")
    objs = (a, b)
    if full.eq_objtype[k] == mujoco.mjtObj.mjOBJ_SITE:
        objs = tuple(int(full.site_bodyid[s]) for s in (a, b) if s >= 0)
    between = joints_between(full, *(objs if len(objs) == 2 else (objs[0], 0)))
    handle = mocap_handle(full, k)
    if handle is not None and any(j in arm for j in between):
        return SetAside(
            "equality constraint",
            name,
            f"ties the arm's body to mocap body {bnames[handle]!r}: the simulation's handle that "
            "drags it (a constraint force in MuJoCo's step), not a part of the arm: its J, M "
            "and gravity are the arm's own",
        )
    if not full.eq_active0[k] and any(j in arm for j in between):
        return SetAside(
            "equality constraint",
            name,
            'inactive in the file (active="false"): it constrains nothing unless a simulation '
            "turns it on, and the arm's numbers are those without it",
        )
    if any(j in arm for j in between):
        bodies = [x for x in objs if x in moved]
        raise UnsupportedFeatureError(
            "equality constraint on a body the arm moves",
            f"equality {name!r} (body {bnames[bodies[0]]!r})",
            "a constraint on the arm's bodies changes its motion; "
            "the library handles an open chain",
        )
    if any(x in moved for x in objs):
        held = ", ".join(repr(jnames[j]) for j in between) or "none"
        return SetAside(
            "equality constraint",
            name,
            "joins bodies that move with the arm but only relative to each other "
            f"through held joints ({held}): it cannot change the arm's J, M or "
            "gravity",
        )
    return SetAside("equality constraint", name, "acts on held bodies only")


def equality_bodies(model: mujoco.MjModel, k: int) -> tuple[int, int]:
    """The two bodies of a connect or weld (site-defined ones: the sites' bodies; 0 the world)."""
    a, b = int(model.eq_obj1id[k]), int(model.eq_obj2id[k])
    if model.eq_objtype[k] == mujoco.mjtObj.mjOBJ_SITE:
        return int(model.site_bodyid[a]), int(model.site_bodyid[b])
    return a, max(b, 0)


def mocap_handle(model: mujoco.MjModel, k: int) -> int | None:
    """The mocap body a connect or weld ``k`` ties to, or None (not one, or not a mocap).

    A mocap body is placed by the simulation's ``mocap_pos``/``mocap_quat``, not by physics:
    a constraint to it is a handle that drags the other body, not part of a mechanism.
    """
    if int(model.eq_type[k]) not in (int(mujoco.mjtEq.mjEQ_CONNECT), int(mujoco.mjtEq.mjEQ_WELD)):
        return None
    for body in equality_bodies(model, k):
        if body > 0 and model.body_mocapid[body] >= 0:
            return body
    return None


def _joint_equality(full: mujoco.MjModel, k: int, arm: set[int], jnames: Sequence[str]) -> SetAside:
    """Joint equality ``k`` among held joints (a gripper's URDF mimic), set aside.

    One that reaches an arm joint is the arm's coupling (`redundancy.model.coupled_chain`)
    and never comes here.
    """
    own = mujoco.mj_id2name(full, mujoco.mjtObj.mjOBJ_EQUALITY, k)
    a, b = int(full.eq_obj1id[k]), int(full.eq_obj2id[k])
    shown = own or " = ".join(jnames[j] for j in (a, b) if j >= 0)
    return SetAside(
        "joint equality",
        shown,
        f"couples held joints only; their held values follow it ({coupling_text(full, k, jnames)})",
    )


def _tendon(
    full: mujoco.MjModel,
    t: int,
    arm: set[int],
    moved: set[int],
    jnames: Sequence[str],
    bnames: Sequence[str],
) -> SetAside:
    """Tendon ``t`` set aside, or refused when it wraps an arm joint or a body the arm moves."""
    name = mujoco.mj_id2name(full, mujoco.mjtObj.mjOBJ_TENDON, t) or f"tendon {t}"
    lo, n = int(full.tendon_adr[t]), int(full.tendon_num[t])
    for w in range(lo, lo + n):
        wtype = mujoco.mjtWrap(full.wrap_type[w])
        obj = int(full.wrap_objid[w])
        if wtype == mujoco.mjtWrap.mjWRAP_JOINT and obj in arm:
            raise UnsupportedFeatureError(
                "tendon on an arm joint",
                f"tendon {name!r} (arm joint {jnames[obj]!r})",
                "Pinocchio has no tendons; the engines would see different arms",
            )
        if wtype == mujoco.mjtWrap.mjWRAP_SITE and int(full.site_bodyid[obj]) in moved:
            raise UnsupportedFeatureError(
                "tendon through a body the arm moves",
                f"tendon {name!r} (body {bnames[int(full.site_bodyid[obj])]!r})",
                "Pinocchio has no tendons; the engines would see different arms",
            )
    return SetAside("tendon", name, "spans held joints or bodies only")


def _actuator(
    full: mujoco.MjModel, u: int, arm: set[int], moved: set[int], jnames: Sequence[str]
) -> SetAside | None:
    """Actuator ``u`` set aside, None when it drives an arm joint (it stays), or refused."""
    name = mujoco.mj_id2name(full, mujoco.mjtObj.mjOBJ_ACTUATOR, u) or f"actuator {u}"
    trn = mujoco.mjtTrn(full.actuator_trntype[u])
    target = int(full.actuator_trnid[u, 0])
    if trn in (mujoco.mjtTrn.mjTRN_JOINT, mujoco.mjtTrn.mjTRN_JOINTINPARENT):
        if target in arm:
            return None
        return SetAside("actuator", name, f"drives held joint {jnames[target]!r}")
    if trn == mujoco.mjtTrn.mjTRN_TENDON:
        if _fixed_over(full, target, arm):
            return SetAside("actuator", name, TENDON_ON_CHAIN)
        return SetAside("actuator", name, "drives a tendon of held joints")
    # site, slider-crank (sites) or body (adhesion) transmissions
    if trn == mujoco.mjtTrn.mjTRN_BODY:
        bodies = [target]
    else:
        bodies = [int(full.site_bodyid[i]) for i in full.actuator_trnid[u] if i >= 0]
    if any(b in moved for b in bodies):
        raise transmission_refusal(int(trn), name)
    return SetAside("actuator", name, "acts on held bodies only")


def joints_between(full: mujoco.MjModel, a: int, b: int) -> list[int]:
    """Joints on the tree path between bodies ``a`` and ``b`` (their relative pose's joints)."""

    def up(body: int) -> list[int]:
        out = [body]
        while body != 0:
            body = int(full.body_parentid[body])
            out.append(body)
        return out

    pa, pb = up(a), up(b)
    common = next(x for x in pa if x in pb)
    path = pa[: pa.index(common)] + pb[: pb.index(common)]
    starts = {body: int(full.body_jntadr[body]) for body in path}
    return [j for body in path for j in range(starts[body], starts[body] + full.body_jntnum[body])]


def delete_couplings(spec: mujoco.MjSpec, full: mujoco.MjModel, arm: set[int]) -> None:
    """Delete what `check_couplings` set aside, and sensors of deleted elements."""
    mjobj = mujoco.mjtObj
    kept_actuators = {
        u
        for u in range(full.nu)
        if mujoco.mjtTrn(full.actuator_trntype[u])
        in (mujoco.mjtTrn.mjTRN_JOINT, mujoco.mjtTrn.mjTRN_JOINTINPARENT)
        and int(full.actuator_trnid[u, 0]) in arm
    }
    sensors = list(spec.sensors)
    for k in range(full.nsensor):
        kind, obj = int(full.sensor_objtype[k]), int(full.sensor_objid[k])
        gone = (
            (kind == mjobj.mjOBJ_JOINT and obj not in arm)
            or (kind == mjobj.mjOBJ_ACTUATOR and obj not in kept_actuators)
            or kind in (mjobj.mjOBJ_TENDON, mjobj.mjOBJ_EQUALITY)
        )
        if gone:
            spec.delete(sensors[k])
    for u, actuator in enumerate(list(spec.actuators)):
        if u not in kept_actuators:
            spec.delete(actuator)
    for el in [*spec.equalities, *spec.tendons]:
        spec.delete(el)
