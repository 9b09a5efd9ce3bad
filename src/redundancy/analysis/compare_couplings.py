"""The couplings two descriptions of one robot declare: URDF mimics, MJCF joint equalities.

Both reach MuJoCo's model of the whole robot as joint equalities (the loader writes a URDF
``<mimic>`` as one): ``q1 - ref1 = c0 + c1 x + ... + c4 x^4``, ``x = q2 - ref2``. Two files may
write one coupling with other references, so the couplings are compared as functions: the
follower's value at five leader values across the leader's range (a polynomial of degree 4 is
fixed by five values), in the joints' own units.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import mujoco
import numpy as np
from numpy.typing import NDArray

from ..model.couplings import coupling_text
from ..model.names import display_names
from ..model.scales import scaled_error
from .comparison import Finding

Array = NDArray[np.float64]

#: Leader values sampled per coupling (a degree-4 polynomial is fixed by five).
SAMPLES = 5


@dataclass(frozen=True)
class Coupling:
    """One active joint equality of the whole robot.

    Attributes:
        follower: The coupled joint (joint1).
        leader: The joint it follows ("" for an equality that fixes it).
        text: The equality as the file's joints see it (``fb = 0.6 - 1 fa``).
        value: The follower's value [rad or m] at a leader value [rad or m].
        range: The leader's range, or (-1, 1) where it has none [rad or m].
    """

    follower: str
    leader: str
    text: str
    value: Callable[[Array], Array]
    range: tuple[float, float]


def couplings(model: mujoco.MjModel) -> dict[str, Coupling]:
    """The active joint equalities of ``model`` (the whole robot's), by follower name."""
    names = display_names(model, mujoco.mjtObj.mjOBJ_JOINT)
    out: dict[str, Coupling] = {}
    for k in range(model.neq):
        if model.eq_type[k] != mujoco.mjtEq.mjEQ_JOINT or not model.eq_active0[k]:
            continue
        j1, j2 = int(model.eq_obj1id[k]), int(model.eq_obj2id[k])
        ref1 = float(model.qpos0[model.jnt_qposadr[j1]])
        ref2 = float(model.qpos0[model.jnt_qposadr[j2]]) if j2 >= 0 else 0.0
        c = np.array(model.eq_data[k][:5], dtype=float)
        limited = j2 >= 0 and bool(model.jnt_limited[j2])
        lo, hi = (float(v) for v in model.jnt_range[j2]) if limited else (-1.0, 1.0)

        def value(x: Array, c: Array = c, ref1: float = ref1, ref2: float = ref2) -> Array:
            s = np.asarray(x, dtype=float) - ref2
            return ref1 + sum(c[i] * s**i for i in range(5))

        leader = names[j2] if j2 >= 0 else ""
        text = coupling_text(model, k, names)
        out[names[j1]] = Coupling(names[j1], leader, text, value, (lo, hi))
    return out


@dataclass(frozen=True)
class CouplingDifference:
    """A coupling one side declares and the other not, or declares differently.

    Attributes:
        follower: The follower's name in A (in B where only B couples it).
        where: ``"joint 'f'"`` in A's names (B's in brackets when they differ).
        a: A's coupling text, or None where A has none.
        b: B's coupling text, or None.
        error: Largest difference of the follower's value over the leader's range [rad or m]
            (inf for a missing coupling or another leader).
        a_values: A's follower values at the sampled leader values (empty when missing).
        b_values: B's, likewise.
    """

    follower: str
    where: str
    a: str | None
    b: str | None
    error: float
    a_values: Array
    b_values: Array


def compare_couplings(
    model_a: mujoco.MjModel, model_b: mujoco.MjModel, a_to_b: Mapping[str, str]
) -> list[CouplingDifference]:
    """Every coupling of A against B's coupling of the same follower (joint names mapped).

    Args:
        model_a: A's model of the whole robot.
        model_b: B's model of the whole robot.
        a_to_b: A's joint name -> B's, for joints whose names differ (others match by name).

    Returns:
        One entry per follower either side couples, in A's order then B's: the coupling texts,
        and the follower values over the leader's range where both couple it to one leader.
    """
    ca, cb = couplings(model_a), couplings(model_b)
    b_to_a = {nb: na for na, nb in a_to_b.items()}
    out: list[CouplingDifference] = []
    empty = np.zeros(0)
    for name, c in ca.items():
        nb = a_to_b.get(name, name)
        where = f"joint {name!r}" + (f" [{nb!r}]" if nb != name else "")
        d = cb.get(nb)
        if d is None:
            out.append(CouplingDifference(name, where, c.text, None, np.inf, empty, empty))
            continue
        if a_to_b.get(c.leader, c.leader) != d.leader:
            out.append(CouplingDifference(name, where, c.text, d.text, np.inf, empty, empty))
            continue
        x = np.linspace(c.range[0], c.range[1], SAMPLES)
        va, vb = c.value(x), d.value(x)
        err = float(np.max(np.abs(va - vb)))
        out.append(CouplingDifference(name, where, c.text, d.text, err, va, vb))
    for name, d in cb.items():
        na = b_to_a.get(name, name)
        if na not in ca:
            out.append(CouplingDifference(na, f"joint {na!r}", None, d.text, np.inf, empty, empty))
    return out


def coupling_findings(
    model_a: mujoco.MjModel,
    model_b: mujoco.MjModel,
    a_to_b: Mapping[str, str],
    length: float,
    tol: float,
) -> tuple[list[Finding], float]:
    """`compare_couplings` as the comparison's findings, and its largest relative error.

    Args:
        model_a: A's model of the whole robot.
        model_b: B's model of the whole robot.
        a_to_b: A's joint name -> B's.
        length: A's length scale, a slide follower's size [m] (a hinge's is 1 rad).
        tol: Relative tolerance [-].

    Returns:
        The findings (missing couplings and other leaders with an infinite error) and the
        largest error of the couplings both sides give the same leader [-].
    """
    found: list[Finding] = []
    largest = 0.0
    for d in compare_couplings(model_a, model_b, a_to_b):
        if not np.isfinite(d.error):
            found.append(Finding("coupling", d.where, d.a, d.b, np.inf))
            continue
        j = mujoco.mj_name2id(model_a, mujoco.mjtObj.mjOBJ_JOINT, d.follower)
        slide = j >= 0 and model_a.jnt_type[j] == mujoco.mjtJoint.mjJNT_SLIDE
        err = scaled_error(d.a_values, d.b_values, length if slide else 1.0)
        largest = max(largest, err)
        if err > tol:
            note = "the follower's values differ over the leader's range"
            found.append(Finding("coupling", d.where, d.a, d.b, err, note))
    return found, largest
