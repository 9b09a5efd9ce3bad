"""MuJoCo's equality constraint rows of a chain's loops: the `Closure` a `CouplingMap` solves.

The residuals and Jacobians are MuJoCo's own (``mj_makeConstraint``: ``efc_pos`` and ``efc_J``
of the ``<connect>``, ``<weld>`` and ``<joint>`` equalities that couple the chain), on a copy of
the whole robot's model with contacts, joint limits and friction loss off (only equality
rows), the robot's other joints at rest.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence

import mujoco
import numpy as np
from numpy.typing import NDArray

from .threads import PerThread

Array = NDArray[np.float64]


class MujocoClosure:
    """h(x) and dh/dx of the equalities ``eq_ids`` of ``model``, x the chain joints' values.

    Args:
        model: MuJoCo's compiled model of the whole robot.
        qpos: The whole robot at rest (its held joints' values).
        joints: The chain model's joint ids in ``model``, in the chain's order (hinge, slide).
        eq_ids: The equalities whose rows are h.
    """

    def __init__(
        self, model: mujoco.MjModel, qpos: Array, joints: Sequence[int], eq_ids: Sequence[int]
    ) -> None:
        m = copy.deepcopy(model)
        off = mujoco.mjtDisableBit
        # Only equality rows: no contacts, limits, friction loss; a dense efc_J to read.
        m.opt.disableflags |= off.mjDSBL_CONTACT | off.mjDSBL_LIMIT | off.mjDSBL_FRICTIONLOSS
        m.opt.disableflags &= ~int(off.mjDSBL_EQUALITY)
        m.opt.jacobian = mujoco.mjtJacobian.mjJAC_DENSE
        self.model = m
        self._qpos = np.array(qpos, dtype=float)
        self._qadr = np.array([m.jnt_qposadr[j] for j in joints], dtype=np.intp)
        self._dofs = np.array([m.jnt_dofadr[j] for j in joints], dtype=np.intp)
        self._eqs = tuple(int(k) for k in eq_ids)
        eq = mujoco.mjtObj.mjOBJ_EQUALITY
        names = [mujoco.mj_id2name(m, eq, k) or f"{k}" for k in range(m.neq)]
        self._data = PerThread(self._new_data).get
        # The rows' owners, read once at rest (their count does not change with the pose).
        d = self._data()
        self._fill(d, self._qpos[self._qadr])
        rows = self._selected(d)
        self.row_names: tuple[str, ...] = tuple(names[int(d.efc_id[i])] for i in rows)
        # Only equality rows are made (the rest is disabled), so their count and order are
        # the same at every pose: the rows and columns to read are indexed once.
        self._nefc = int(d.nefc)
        self._pick = np.ix_(rows, self._dofs)
        self._rows = rows

    def _new_data(self) -> mujoco.MjData:
        d = mujoco.MjData(self.model)
        d.qpos[:] = self._qpos
        d.eq_active[:] = 0
        d.eq_active[list(self._eqs)] = 1  # the chain's couplings only
        return d

    def _fill(self, d: mujoco.MjData, x: Array) -> None:
        d.qpos[self._qadr] = x
        # Body and site frames (connect and weld anchors), then cdof (the rows' Jacobians),
        # then the constraint rows themselves.
        mujoco.mj_kinematics(self.model, d)
        mujoco.mj_comPos(self.model, d)
        mujoco.mj_makeConstraint(self.model, d)

    def _selected(self, d: mujoco.MjData) -> NDArray[np.intp]:
        eq = int(mujoco.mjtConstraint.mjCNSTR_EQUALITY)
        return np.flatnonzero(d.efc_type[: d.nefc] == eq)

    def rows(self, x: Array) -> tuple[Array, Array]:
        """Residuals (rows,) [m or rad] and their Jacobian (rows, nx) at chain pose ``x``."""
        d = self._data()
        self._fill(d, x)
        nv, n = self.model.nv, int(d.nefc)
        rows, pick = self._rows, self._pick
        if n != self._nefc:  # not met: kept so that a row that appears is not misread
            rows = self._selected(d)
            pick = np.ix_(rows, self._dofs)
        J = d.efc_J[: n * nv].reshape(n, nv)
        return d.efc_pos[rows], J[pick]
