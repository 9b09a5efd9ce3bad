"""The couplings two descriptions of one robot declare: URDF mimics, MJCF joint equalities.

Both reach MuJoCo's model of the whole robot as joint equalities (the loader writes a URDF
``<mimic>`` as one; `redundancy.model.couplings.coupling_value`). Two files may write one
coupling with other references, so the couplings are compared as functions: the follower's
value at five leader values across the leader's range (a polynomial of degree 4 is fixed by
five values), in the joints' own units.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import mujoco
import numpy as np

from ..model.couplings import coupling_text, coupling_value
from ..model.names import display_names
from ..model.scales import scaled_error
from .comparison import Finding

#: Leader values sampled per coupling (a degree-4 polynomial is fixed by five).
SAMPLES = 5

_NOTE = "the follower's values differ over the leader's range"


def _couplings(model: mujoco.MjModel, names: Sequence[str]) -> dict[str, tuple[int, str]]:
    """The active joint equalities of ``model``: follower name -> (equality id, leader name)."""
    out: dict[str, tuple[int, str]] = {}
    for k in range(model.neq):
        if model.eq_type[k] == mujoco.mjtEq.mjEQ_JOINT and model.eq_active0[k]:
            j2 = int(model.eq_obj2id[k])
            out[names[int(model.eq_obj1id[k])]] = (k, names[j2] if j2 >= 0 else "")
    return out


def _values(model: mujoco.MjModel, k: int, x: np.ndarray) -> np.ndarray:
    """Equality ``k``'s follower values at leader values ``x`` [rad or m]."""
    return np.array([coupling_value(model, k, float(v)) for v in x])


def coupling_findings(
    model_a: mujoco.MjModel,
    model_b: mujoco.MjModel,
    a_to_b: Mapping[str, str],
    length: float,
    tol: float,
) -> tuple[list[Finding], float]:
    """Every coupling of A against B's coupling of the same follower (joint names mapped).

    Args:
        model_a: A's model of the whole robot.
        model_b: B's model of the whole robot.
        a_to_b: A's joint name -> B's, for joints whose names differ (others match by name).
        length: A's length scale, a slide follower's size [m] (a hinge's is 1 rad).
        tol: Relative tolerance [-].

    Returns:
        The findings, in A's order then B's, with both rules as text (None on the side that has
        none; an infinite error for a missing coupling or another leader), and the largest
        relative error of the couplings both sides give one leader [-].
    """
    names_a = display_names(model_a, mujoco.mjtObj.mjOBJ_JOINT)
    names_b = display_names(model_b, mujoco.mjtObj.mjOBJ_JOINT)
    ca, cb = _couplings(model_a, names_a), _couplings(model_b, names_b)
    found: list[Finding] = []
    largest = 0.0
    for name, (k, leader) in ca.items():
        nb = a_to_b.get(name, name)
        where = f"joint {name!r}" + (f" [{nb!r}]" if nb != name else "")
        text = coupling_text(model_a, k, names_a)
        if nb not in cb:
            found.append(Finding("coupling", where, text, None, np.inf))
            continue
        kb, leader_b = cb[nb]
        text_b = coupling_text(model_b, kb, names_b)
        if a_to_b.get(leader, leader) != leader_b:
            found.append(Finding("coupling", where, text, text_b, np.inf))
            continue
        j2 = int(model_a.eq_obj2id[k])
        limited = j2 >= 0 and bool(model_a.jnt_limited[j2])
        lo, hi = model_a.jnt_range[j2] if limited else (-1.0, 1.0)
        x = np.linspace(lo, hi, SAMPLES)
        slide = model_a.jnt_type[model_a.eq_obj1id[k]] == mujoco.mjtJoint.mjJNT_SLIDE
        err = scaled_error(
            _values(model_a, k, x), _values(model_b, kb, x), length if slide else 1.0
        )
        largest = max(largest, err)
        if err > tol:
            found.append(Finding("coupling", where, text, text_b, err, _NOTE))
    b_to_a = {nb: na for na, nb in a_to_b.items()}
    for name, (kb, _) in cb.items():
        na = b_to_a.get(name, name)
        if na not in ca:
            text_b = coupling_text(model_b, kb, names_b)
            found.append(Finding("coupling", f"joint {na!r}", None, text_b, np.inf))
    return found, largest
