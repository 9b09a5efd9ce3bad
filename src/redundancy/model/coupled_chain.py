"""Coupled joints and closed loops on the chain to the tool: which joints the arm's coordinates are.

A chain may contain joints that are not free: a URDF ``<mimic>`` and an MJCF joint equality
make a follower a polynomial of its leader; an ``<equality><connect>`` or ``<weld>`` closes a
loop (a four-bar, a Robotiq 2F-85's finger). `coupled_system` reads, from MuJoCo's compiled
model of the whole robot, the joints the chain's couplings reach (transitively: a follower's
follower, the joints on a loop's path, a loop of a follower), and chooses the **independent**
ones, the arm's coordinates:

* a joint equality's follower (``joint1``) is never independent;
* of a loop's joints, as many stay independent as the loop leaves free: the chain's joints
  first, the actuated ones first (a joint an actuator drives, directly or through a fixed
  tendon), then joints off the chain; the dependent ones are chosen greedily from the other
  end, each one taken when it raises the rank of the constraint Jacobian at rest
  (MuJoCo's own rows, `redundancy.engines.mujoco_closure`);
* a joint off the chain left free that moves nothing on the chain (the other finger's
  passive freedom in a gripper whose tool is one pad) is held at rest.

`coupling_map` then builds the `redundancy.engines.coupling.CouplingMap` every engine of the
arm is seen through. Refused: a joint that two joint equalities determine (contradictory), a
cycle of joint equalities (circular), a tendon equality on the chain's joints, a loop through
a ball or free joint, a loop that leaves the chain no independent joint.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import mujoco
import numpy as np

from ..engines.coupling import CouplingMap, Polynomial
from ..engines.mujoco_closure import MujocoClosure
from ..errors import ModelError, UnsupportedFeatureError
from .couplings import coupling_text, equality_bodies, joints_between, mocap_handle
from .names import display_names
from .selection import Array, joint_kind

_EQ = mujoco.mjtEq


@dataclass(frozen=True)
class CoupledSystem:
    """The chain's coupled joints as read from the file (MuJoCo ids of the whole robot).

    Attributes:
        joints: Every joint the arm moves (the chain's and the followers'), MuJoCo's order.
        independent: The arm's coordinates among them, in MuJoCo's order.
        held: Joints on the loops left free but moving nothing on the chain: held at rest.
        equalities: The equalities that couple ``joints`` (joint equalities and loops).
        loops: The ``<connect>`` and ``<weld>`` among them.
        followers: Follower joint name -> what determines it.
        rest: The whole robot's qpos at rest with the loops closed.
    """

    joints: tuple[int, ...]
    independent: tuple[int, ...]
    held: tuple[int, ...]
    equalities: tuple[int, ...]
    loops: tuple[int, ...]
    followers: dict[str, str] = field(default_factory=dict)
    rest: Array | None = None


def _name(model: mujoco.MjModel, k: int) -> str:
    return mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_EQUALITY, k) or f"equality {k}"


def _reach(model: mujoco.MjModel, chain: set[int]) -> tuple[set[int], list[int], list[int]]:
    """The joints the chain's couplings reach, and the joint equalities and loops on them."""
    # An inactive equality constrains nothing; one to a mocap body is a simulation's handle.
    active = [k for k in range(model.neq) if model.eq_active0[k] and mocap_handle(model, k) is None]
    joints, eqs, loops = set(chain), set(), set()
    grew = True
    while grew:
        grew = False
        for k in active:
            kind = int(model.eq_type[k])
            if kind == int(_EQ.mjEQ_JOINT):
                pair = {int(model.eq_obj1id[k]), int(model.eq_obj2id[k])} - {-1}
                if pair & joints and k not in eqs:
                    eqs.add(k)
                    joints |= pair
                    grew = True
            elif kind in (int(_EQ.mjEQ_CONNECT), int(_EQ.mjEQ_WELD)) and k not in loops:
                path = set(joints_between(model, *equality_bodies(model, k)))
                if path & joints:
                    loops.add(k)
                    joints |= path
                    grew = True
    return joints, sorted(eqs), sorted(loops)


def _refuse_tendon_couplings(model: mujoco.MjModel, joints: set[int]) -> None:
    """A tendon equality that reaches a coupled joint: its coupling is not a joint function."""
    names = display_names(model, mujoco.mjtObj.mjOBJ_JOINT)
    for k in range(model.neq):
        if not model.eq_active0[k] or model.eq_type[k] != _EQ.mjEQ_TENDON:
            continue
        for t in (int(model.eq_obj1id[k]), int(model.eq_obj2id[k])):
            if t < 0:
                continue
            lo, n = int(model.tendon_adr[t]), int(model.tendon_num[t])
            hit = [
                int(model.wrap_objid[w])
                for w in range(lo, lo + n)
                if model.wrap_type[w] == mujoco.mjtWrap.mjWRAP_JOINT
                and int(model.wrap_objid[w]) in joints
            ]
            if hit:
                raise UnsupportedFeatureError(
                    "tendon coupling on the arm",
                    f"equality {_name(model, k)!r} (tendon over joint {names[hit[0]]!r})",
                    "a tendon equality couples tendon lengths, not joints: the arm's joints "
                    "are served with joint equalities (<equality><joint>), URDF <mimic> and "
                    "loops closed by <connect> or <weld>",
                )


def _check_polynomials(model: mujoco.MjModel, eqs: Sequence[int]) -> list[int]:
    """The joint equalities, each leader's before its followers'; contradictions refused."""
    names = display_names(model, mujoco.mjtObj.mjOBJ_JOINT)
    by_follower: dict[int, int] = {}
    for k in eqs:
        j1 = int(model.eq_obj1id[k])
        if j1 in by_follower:
            other = by_follower[j1]
            raise ModelError(
                f"contradictory couplings: joint {names[j1]!r} follows two joint equalities, "
                f"{_name(model, other)!r} ({coupling_text(model, other, names)}) and "
                f"{_name(model, k)!r} ({coupling_text(model, k, names)}); a joint may follow "
                "one coupling"
            )
        by_follower[j1] = k
    ordered: list[int] = []
    state: dict[int, int] = {}  # 1: on the path, 2: done

    def visit(j: int, path: list[int]) -> None:
        if state.get(j) == 2 or j not in by_follower:
            return
        if state.get(j) == 1:
            cycle = [*path[path.index(j) :], j]
            shown = " -> ".join(repr(names[i]) for i in cycle)
            raise ModelError(
                f"circular couplings: joints {shown} follow each other (URDF <mimic> or MJCF "
                "joint equalities); one of them must be a free leader"
            )
        state[j] = 1
        leader = int(model.eq_obj2id[by_follower[j]])
        if leader >= 0:
            visit(leader, [*path, j])
        state[j] = 2
        ordered.append(by_follower[j])

    for j in sorted(by_follower):
        visit(j, [])
    return ordered


def actuated_joints(model: mujoco.MjModel) -> set[int]:
    """Joints an actuator drives: by a joint transmission, or in a fixed tendon it pulls."""
    out: set[int] = set()
    trn = mujoco.mjtTrn
    for u in range(model.nu):
        kind, target = model.actuator_trntype[u], int(model.actuator_trnid[u, 0])
        if kind in (trn.mjTRN_JOINT, trn.mjTRN_JOINTINPARENT):
            out.add(target)
        elif kind == trn.mjTRN_TENDON:
            lo, n = int(model.tendon_adr[target]), int(model.tendon_num[target])
            out |= {
                int(model.wrap_objid[w])
                for w in range(lo, lo + n)
                if model.wrap_type[w] == mujoco.mjtWrap.mjWRAP_JOINT
            }
    return out


def coupled_system(
    model: mujoco.MjModel, chain: Sequence[int], qpos: Array
) -> CoupledSystem | None:
    """The chain's coupled joints and the arm's coordinates among them (None: no coupling).

    Args:
        model: MuJoCo's compiled model of the whole robot.
        chain: The hinge and slide joints on the path to the tool, in chain order.
        qpos: The whole robot at rest.

    Raises:
        ModelError: Contradictory or circular joint equalities (naming the joints), or a
            loop that leaves no independent joint on the chain.
        UnsupportedFeatureError: A tendon equality on the coupled joints, or a loop through
            a ball or free joint.
    """
    joints, eqs, loops = _reach(model, set(chain))
    _refuse_tendon_couplings(model, joints)
    if not eqs and not loops:
        return None
    names = display_names(model, mujoco.mjtObj.mjOBJ_JOINT)
    for j in sorted(joints):
        if joint_kind(model, j) not in ("hinge", "slide"):
            k = next(k for k in loops if j in joints_between(model, *equality_bodies(model, k)))
            raise UnsupportedFeatureError(
                "loop through a ball or free joint",
                f"equality {_name(model, k)!r} (joint {names[j]!r})",
                "a loop's closure is served as a function of hinge and slide joints",
            )
    ordered = _check_polynomials(model, eqs)
    followers = {int(model.eq_obj1id[k]) for k in ordered}
    all_joints = sorted(joints)
    texts = {
        names[int(model.eq_obj1id[k])]: f"joint equality {coupling_text(model, k, names)}"
        for k in ordered
    }
    rest = np.array(qpos, dtype=float)
    if not loops:
        independent = tuple(j for j in all_joints if j not in followers)
        if not independent:
            raise ModelError(
                "the chain's joints are all fixed by joint equalities without a leader "
                f"({', '.join(repr(names[j]) for j in all_joints)}): the arm does not move"
            )
        return CoupledSystem(tuple(all_joints), independent, (), tuple(ordered), (), texts, rest)
    return _with_loops(model, list(chain), all_joints, ordered, loops, followers, texts, rest)


def _with_loops(
    model: mujoco.MjModel,
    chain: list[int],
    joints: list[int],
    ordered: list[int],
    loops: list[int],
    followers: set[int],
    texts: dict[str, str],
    rest: Array,
) -> CoupledSystem:
    """The loops' dependent joints (greedy on the rank of MuJoCo's rows), closed at rest."""
    names = display_names(model, mujoco.mjtObj.mjOBJ_JOINT)
    eqs = tuple(sorted([*ordered, *loops]))
    closure = MujocoClosure(model, rest, joints, eqs)
    x0 = rest[[int(model.jnt_qposadr[j]) for j in joints]]
    _, H = closure.rows(x0)
    actuated = actuated_joints(model)

    def preference(j: int) -> tuple[int, int]:  # lower: rather independent
        on_chain = j in chain
        group = (0 if j in actuated else 1) if on_chain else (2 if j in actuated else 3)
        return (4 if j in followers else group, chain.index(j) if on_chain else j)

    rank = np.linalg.matrix_rank(H) if H.size else 0
    dependent: list[int] = []
    for j in sorted(joints, key=preference, reverse=True):
        if len(dependent) == rank:
            break
        trial = [joints.index(i) for i in [*dependent, j]]
        if np.linalg.matrix_rank(H[:, trial]) == len(trial):
            dependent.append(j)
    free = [j for j in joints if j not in dependent]
    cmap = CouplingMap(
        [names[j] for j in joints],
        [joints.index(j) for j in free],
        x0,
        (),
        closure,
        [joints.index(j) for j in dependent],
    )
    q0 = x0[[joints.index(j) for j in free]]
    closed = cmap.at(q0, q0.tolist())
    # A free joint off the chain whose motion moves no chain joint: held at rest.
    rows = [joints.index(j) for j in chain]
    held = [
        j
        for i, j in enumerate(free)
        if j not in chain and float(np.max(np.abs(closed.G[rows, i]), initial=0.0)) <= 1e-9
    ]
    independent = tuple(j for j in free if j not in held)
    if not independent:
        raise ModelError(
            f"the loop closed by equality {_name(model, loops[0])!r} leaves the chain no "
            "independent joint: the mechanism does not move"
        )
    for j, value in zip(joints, closed.x, strict=True):
        rest[int(model.jnt_qposadr[j])] = value
    by = ", ".join(repr(names[i]) for i in independent)
    for j in dependent:
        if names[j] not in texts:
            own = [k for k in loops if j in joints_between(model, *equality_bodies(model, k))]
            shown = ", ".join(repr(_name(model, k)) for k in own or loops)
            texts[names[j]] = f"closes the loop of equality {shown}; moved by {by}"
    moving = tuple(j for j in joints if j not in held)
    return CoupledSystem(moving, independent, tuple(held), eqs, tuple(loops), texts, rest)


def coupling_map(model: mujoco.MjModel, system: CoupledSystem) -> CouplingMap:
    """The `CouplingMap` of a coupled system, over its moving joints in MuJoCo's order."""
    names = display_names(model, mujoco.mjtObj.mjOBJ_JOINT)
    joints = list(system.joints)
    rest = system.rest if system.rest is not None else model.qpos0
    x0 = np.array([rest[int(model.jnt_qposadr[j])] for j in joints])
    independent = [joints.index(j) for j in system.independent]
    if system.loops:
        closure = MujocoClosure(model, rest, joints, system.equalities)
        dependent = [i for i in range(len(joints)) if i not in independent]
        return CouplingMap(
            [names[j] for j in joints], independent, x0, (), closure, dependent, system.followers
        )
    polys = []
    for k in system.equalities:
        j1, j2 = int(model.eq_obj1id[k]), int(model.eq_obj2id[k])
        ref = model.qpos0
        polys.append(
            Polynomial(
                joints.index(j1),
                joints.index(j2) if j2 >= 0 else -1,
                tuple(float(c) for c in model.eq_data[k][:5]),  # type: ignore[arg-type]
                float(ref[model.jnt_qposadr[j1]]),
                float(ref[model.jnt_qposadr[j2]]) if j2 >= 0 else 0.0,
            )
        )
    return CouplingMap(
        [names[j] for j in joints], independent, x0, polys, None, (), system.followers
    )
