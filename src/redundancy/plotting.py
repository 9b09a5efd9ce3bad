"""Figures of the common plots, and matplotlib for the scripts (the ``plot`` extra).

Nothing here changes the user's matplotlib backend or pyplot's state: the figure helpers build a
`matplotlib.figure.Figure` directly (object-oriented API), which a notebook shows inline when it is
a cell's value and which ``fig.savefig(path)`` writes anywhere.
[`pyplot`][redundancy.plotting.pyplot] returns ``matplotlib.pyplot`` as the user configured it
(matplotlib itself falls back to the non-interactive Agg backend where there is no display).

Example:
    >>> import redundancy as rd
    >>> from redundancy.plotting import manipulability_figure
    >>> arm = rd.load(rd.model_path("arm7"), frame="ee")
    >>> fig = manipulability_figure(arm, rd.random_poses(arm, 50))
    >>> fig.savefig("manipulability.png")  # doctest: +SKIP
"""

from __future__ import annotations

from types import ModuleType
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from .analysis import batch
from .arm import Arm, EngineName
from .checks import check_choice, check_pose, check_poses
from .errors import MissingDependencyError, ParameterError
from .linalg import MANIPULABILITY_KINDS, ManipulabilityKind

if TYPE_CHECKING:
    from matplotlib.figure import Figure

#:  The velocity ellipsoids
#: [`velocity_ellipsoid_figure`][redundancy.plotting.velocity_ellipsoid_figure] draws: rows of J and
#: their unit.
ELLIPSOID_KINDS = {"position": (slice(0, 3), "m/s"), "orientation": (slice(3, 6), "rad/s")}


def pyplot() -> ModuleType:
    """``matplotlib.pyplot``, on whatever backend the user (or matplotlib's default) chose.

    Raises:
        MissingDependencyError: matplotlib is not installed (``pip install 'redundancy[plot]'``).
    """
    try:
        import matplotlib.pyplot as plt
    except ImportError as err:
        raise MissingDependencyError("matplotlib", "plot") from err
    return plt


def _figure(**kwargs: object) -> Figure:
    """A new Figure outside pyplot (no backend chosen, no global figure list)."""
    try:
        from matplotlib.figure import Figure
    except ImportError as err:
        raise MissingDependencyError("matplotlib", "plot") from err
    return Figure(**kwargs)  # type: ignore[arg-type]


def manipulability_figure(
    arm: Arm,
    path: ArrayLike,
    kind: ManipulabilityKind = "full",
    s: ArrayLike | None = None,
    engine: EngineName = "mujoco",
    length: float = 1.0,
) -> Figure:
    """Manipulability along a path of poses, with the smallest singular value beside it.

    Args:
        arm: The arm.
        path: Poses along the path, shape (n, nq) [rad or m].
        kind: Which measure (`MANIPULABILITY_KINDS`).
        s: Path parameter per pose, shape (n,) (time [s], arc length...); the pose index
            by default.
        engine: ``"mujoco"`` or ``"pinocchio"``.
        length: Characteristic length for ``"scaled"`` [m].

    Returns:
        The figure: manipulability (top) and sigma_min of the full Jacobian (bottom).

    Raises:
        PoseError: Bad poses.
        ParameterError: ``s`` not of shape (n,), or a bad ``kind`` or ``length``.
        MissingDependencyError: matplotlib is not installed.
    """
    check_choice("manipulability kind", kind, MANIPULABILITY_KINDS)
    Q = check_poses(path, arm.joint_names)
    w = batch.manipulabilities(arm, Q, engine, kind, length)
    sigma_min = batch.singular_values(arm, Q, engine)[:, -1]
    if s is None:
        x, xlabel = np.arange(len(Q), dtype=float), "pose along the path"
    else:
        x, xlabel = np.asarray(s, dtype=float), "path parameter"
        if x.shape != (len(Q),):
            raise ParameterError("s", x.shape, f"of shape ({len(Q)},), one value per pose")
    fig = _figure(figsize=(7.0, 4.5), layout="constrained")
    top, bottom = fig.subplots(2, 1, sharex=True)
    top.plot(x, w, color="C0")
    top.set_ylabel(f"manipulability ({kind})")
    top.set_title(f"{arm.frame}: manipulability along the path ({len(Q)} poses)")
    bottom.plot(x, sigma_min, color="C1")
    bottom.set_ylabel("smallest singular value")
    bottom.set_xlabel(xlabel)
    for ax in (top, bottom):
        ax.grid(True, alpha=0.3)
        ax.set_ylim(bottom=0.0)
    return fig


def velocity_ellipsoid_figure(
    arm: Arm, q: ArrayLike, kind: str = "position", engine: EngineName = "mujoco"
) -> Figure:
    """The tool's velocity ellipsoid at a pose: the tool velocities of unit joint speed.

    The ellipsoid {J_k qdot : |qdot| = 1} of the linear (``"position"``) or angular
    (``"orientation"``) rows J_k of the site Jacobian: its semi-axes are the left singular
    vectors of J_k scaled by its singular values, so a flat axis is a direction the tool
    cannot move in at this pose.

    Args:
        arm: The arm.
        q: The pose, shape (nq,) [rad or m].
        kind: ``"position"`` [m/s per rad/s] or ``"orientation"`` [rad/s per rad/s].
        engine: ``"mujoco"`` or ``"pinocchio"``.

    Returns:
        The figure: the ellipsoid in 3D, its semi-axes drawn, world axes.

    Raises:
        PoseError: A bad pose.
        UnknownNameError: A ``kind`` that is not ``"position"`` or ``"orientation"``.
        MissingDependencyError: matplotlib is not installed.
    """
    check_choice("velocity ellipsoid kind", kind, tuple(ELLIPSOID_KINDS))
    rows, unit = ELLIPSOID_KINDS[kind]
    J = arm.jacobian(check_pose(q, arm.joint_names), engine)[rows]
    U, sigma, _ = np.linalg.svd(J)
    u, v = np.meshgrid(np.linspace(0.0, 2 * np.pi, 40), np.linspace(0.0, np.pi, 20))
    sphere = np.stack([np.cos(u) * np.sin(v), np.sin(u) * np.sin(v), np.cos(v)])
    x, y, z = np.einsum("ij,jkl->ikl", U * sigma, sphere)
    fig = _figure(figsize=(5.5, 5.0), layout="constrained")
    ax = fig.add_subplot(projection="3d")
    ax.plot_surface(x, y, z, alpha=0.25, color="C0", linewidth=0)
    for i in range(3):
        axis = U[:, i] * sigma[i]
        ax.plot(*np.stack([-axis, axis]).T, color=f"C{i + 1}", label=f"sigma {sigma[i]:.3g}")
    r = max(float(sigma[0]), 1e-12)
    ax.set_xlim(-r, r)
    ax.set_ylim(-r, r)
    ax.set_zlim(-r, r)
    ax.set_box_aspect((1.0, 1.0, 1.0))
    ax.set_xlabel(f"x [{unit}]")
    ax.set_ylabel(f"y [{unit}]")
    ax.set_zlabel(f"z [{unit}]")
    ax.set_title(f"{arm.frame}: {kind} velocity ellipsoid (unit joint speed)")
    ax.legend(loc="upper left", fontsize="small")
    return fig


__all__ = ["ELLIPSOID_KINDS", "manipulability_figure", "pyplot", "velocity_ellipsoid_figure"]
