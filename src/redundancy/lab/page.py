"""The lab: lesson 5.2's interactive arm, served as a local web page with viser.

``redundancy lab [MODEL.xml] [--frame NAME]`` starts it. The page shows the arm drawn from its
geoms (a colour per link), held by `redundancy.lab.sim.LabSim` (PD control with gravity
compensation, stepped in real time by `redundancy.lab.sim.RealTimeRunner`), with sliders for the
joint targets and the controller's damping, a choice of armature, readouts, the six singular
values as bars and three live plots.

Redundancy to touch: a self-motion slider moves the elbow along the null space with the tool
held; a gizmo at the tool drags it (damped least squares with a null-space posture term);
the tool's translational velocity ellipsoid and, near a singular pose, the lost directions
are drawn at the tool.

**One bench, shared.** The state lives in the server: a browser that disconnects and
reconnects gets the current scene, controls and plots, and the physics never waits for a
browser; a second browser sees and drives the same arm (the readouts count the browsers).
"reset pose" puts the arm back at its keyframe and keeps the settings; "reset all" also
restores kd, armature, contact forces, pause and speed, so the next user starts from the
lesson's defaults.

The plots show time relative to now (``t - now``, fixed windows ending at 0), with axis
ranges and tick labels computed here: symmetric speed and torque axes with the limits drawn
as dashed lines, and sigma_min on a log axis from 1e-6 up.

Readouts are rendered as an HTML table whose value cells carry ``data-readout`` attributes
(`READOUT_KEYS`), so tests and scripts can read them from the DOM.
"""

from __future__ import annotations

import contextlib
import html
import io
import json
import math
import socket
import sys
import threading
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from ..arm import Arm
from ..errors import MissingDependencyError
from .axes import log_axis, nice_ceil
from .axes import symmetric_axis as symmetric_axis  # still importable from the page
from .geometry import (
    BASE_COLOR,
    drawn_geoms,
    geom_mesh,
    link_colors,
    mat_to_quat,
    quat_to_mat,
)
from .network import check_address, is_ip, is_loopback, machine_names
from .plots import external_scales, speed_scales, symmetric_axes, time_axis
from .sim import (
    KD,
    LOST_SIGMA,
    OBSERVER_GAIN,
    PUSH_MAX,
    RATES,
    SIGMA_WINDOW,
    SPEED_WINDOW,
    LabReadouts,
    LabSim,
    RealTimeRunner,
    solve_ik,
)

try:
    import viser
    import viser.uplot
except ImportError as _err:  # pragma: no cover - exercised only without the extra
    raise MissingDependencyError("viser", "lab") from _err

Array = NDArray[np.float64]

#: Arrow sizes [m] (viser's shaft radius, head radius, head length): joint axes, and the
#: Jacobian's lost directions.
_AXIS_ARROWS = {"shaft_radius": 0.003, "head_radius": 0.009, "head_length": 0.025}
_LOST_ARROWS = {"shaft_radius": 0.005, "head_radius": 0.015, "head_length": 0.03}
#: Label of the kd slider.
KD_LABEL = "kd (N m s/rad)"
#: Largest kd on its slider [N m s/rad]: the lesson's 5 fits, and the bare wrist's
#: threshold (about 0.62) is marked.
KD_MAX = 6.0
#: Label of the armature choice.
ARMATURE_LABEL = "armature"
#: Choice meaning "the armature as modelled" / "no armature".
ARMATURE_MODELLED = "as modelled"
ARMATURE_ZERO = "0 (bare links)"
#: Buttons.
NUDGE_LABEL = "nudge"
RESET_LABEL = "reset pose"
RESET_ALL_LABEL = "reset all"
PAUSE_LABEL = "pause"
RESUME_LABEL = "resume"
STEP_LABEL = "single step"
CSV_LABEL = "download plotted data (CSV)"
#: Slow-motion choice and its options.
RATE_LABEL = "speed"
RATE_OPTIONS = {f"{r:g}x real time": r for r in RATES}
#: Checkbox that turns contact forces on.
COLLIDE_LABEL = "links collide"
#: The push sliders, one per world axis [N].
PUSH_LABELS = ("push x (N)", "push y (N)", "push z (N)")
#: The external-torque plot's vertical range to start with [N m] (it grows with the data).
EXTERNAL_RANGE = 5.0
#: The self-motion slider [rad of joint motion along the null space].
SELF_MOTION_LABEL = "self-motion (rad)"
SELF_MOTION_RANGE = 3.0
#: View checkboxes.
GIZMO_LABEL = "drag the tool (gizmo)"
ELLIPSOID_LABEL = "velocity ellipsoid"
NAMES_LABEL = "link names"
#: Camera presets (buttons of one group).
VIEW_LABEL = "camera"
VIEWS = ("front", "side", "top")
#: The readout cells' ``data-readout`` keys, with their row labels.
READOUT_KEYS = {
    "sigma_min": "σ_min of J",
    "manipulability": "manipulability",
    "contacts": "self-contacts",
    "lost": "lost directions (σ < 1e-3)",
    "speed": "{joint} speed (rad/s)",
    "peak": "{joint} |speed| peak, 0.2 s (rad/s)",
    "torque": "{joint} motor torque (N m)",
    "contact_mass": "tool's effective mass along its motion (kg)",
    "ellipsoid": "tool speed ellipsoid semi-axes (m/s per rad/s)",
    "drift": "self-motion: tool drift (m)",
    "elbow": "self-motion: elbow moved (m)",
    "ik": "gizmo: tool error of the IK (m)",
    "picked": "clicked link",
    "time": "simulated time (s)",
    "rtf": "real-time factor",
    "browsers": "browsers connected",
}
#: Trail of the tool site: this many positions, one per frame in which it moved by 1 mm.
TRAIL_POINTS = 300
#: Opacity of the links while they are in self-contact, so that the contact markers show.
CONTACT_OPACITY = 0.45
#: Colour of links in self-contact.
CONTACT_COLOR = (230, 40, 40)
#: Contact markers drawn at most.
MAX_CONTACT_MARKERS = 24
#: Readouts and plots are refreshed every this many frames.
GUI_EVERY = 3
#: The velocity ellipsoid is drawn with this many metres per (m/s per rad/s).
ELLIPSOID_SCALE = 0.2
#: Length of a lost-direction arrow [m].
LOST_ARROW = 0.2
#: Floor of the sigma_min plot's log axis (smaller values are drawn on it).
SIGMA_FLOOR = 1e-6
#: The speed plot's dashed lines: the lesson's "at rest" bound [rad/s].
REST_SPEED = 1e-3


def joint_label(arm: Arm, i: int) -> str:
    """Label of joint ``i``'s slider, e.g. ``"j4 (rad)"``."""
    unit = "rad" if arm.joint_types[i] == "hinge" else "m"
    return f"{arm.joint_names[i]} ({unit})"


class LabPage:
    """The viser page of a `LabSim`: scene, controls, readouts, plots.

    Args:
        server: The viser server to draw into.
        sim: The simulation to show and drive.
        runner: The runner stepping it (for pause, single step, speed and the real-time
            factor), or None.
        title: Heading of the control panel.
        tab_title: Title of the browser tab.
    """

    arm: Arm
    reach: float
    base: Array
    sliders: list[Any]

    def __init__(
        self,
        server: viser.ViserServer,
        sim: LabSim,
        runner: RealTimeRunner | None,
        title: str,
        tab_title: str,
    ) -> None:
        self.server = server
        self.sim = sim
        self.runner = runner
        self.arm = sim.arm
        self._frame = 0
        self._last_q: Array | None = None
        self._last_html = ""
        self._trail: list[Array] = []
        self._lock = threading.RLock()
        self._syncing = False
        self._dragging = False
        self._drag_rest: Array | None = None
        self._gizmo_target: Array | None = None
        self._anchor: Array | None = None
        self._self_motion_value = 0.0
        # Poses of the self-motion from the anchor to the slider's value (the anchor alone at
        # 0): the next slider move goes back along it without computing it again.
        self._self_motion_q: Array | None = None
        self._self_motion_text = ("-", "-")
        self._ik_error: float | None = None
        self._picked = "-"
        self._highlighted: frozenset[str] = frozenset()
        self._speed_half = 0.0
        self._build_scene()
        self._build_gui(title, tab_title)
        self._sync_gizmo()
        self.update(sim, force=True)

    # -- scene -----------------------------------------------------------------------------
    def _build_scene(self) -> None:
        scene = self.server.scene
        scene.set_up_direction("+z")
        # Plain lights instead of viser's image-based environment: as clear, and several
        # times cheaper to render where WebGL runs in software (headless browsers, VMs).
        scene.configure_environment_map(None)
        scene.add_light_hemisphere(
            "/lights/sky", sky_color=(255, 255, 255), ground_color=(110, 110, 120), intensity=1.6
        )
        self.reach, self.base = self._reach()
        grid = 2.0 * max(1.0, math.ceil(self.reach * 1.2 * 2) / 2)
        scene.add_grid(
            "/floor", width=grid, height=grid, cell_size=0.1, section_size=0.5, plane="xy"
        )
        self._build_links()
        _, _, anchor, axis, site, rot = self.sim.frames()
        self._build_markers(anchor, axis)
        self._build_gizmo(site, rot)
        position, look_at = self.camera_view("oblique", aspect=1.0)
        self.server.initial_camera.look_at = tuple(look_at)
        self.server.initial_camera.position = tuple(position)
        self.server.initial_camera.fov = math.radians(45.0)

    def _build_links(self) -> None:
        """The arm's geoms, a colour per link, clickable; the link-name labels."""
        scene = self.server.scene
        m = self.sim.model
        self._geoms = drawn_geoms(m)
        colors = link_colors(m)
        self._body_of = [int(m.geom_bodyid[g]) for g in self._geoms]
        self._body_names = {
            b: mujoco.mj_id2name(m, mujoco.mjtObj.mjOBJ_BODY, b) or f"body {b}"
            for b in range(m.nbody)
        }
        self._colors = [colors.get(b, BASE_COLOR) for b in self._body_of]
        self._meshes = []
        for g, color in zip(self._geoms, self._colors, strict=True):
            mesh = geom_mesh(m, g)
            assert mesh is not None
            alpha = float(m.geom_rgba[g, 3])
            handle = scene.add_mesh_simple(
                f"/arm/geom{g}",
                np.asarray(mesh.vertices, dtype=np.float32),
                np.asarray(mesh.faces, dtype=np.uint32),
                color=color,
                opacity=alpha if alpha < 1 else None,
            )
            # Clickable nodes are outlined under the pointer; a click names the link.
            handle.on_click(self._pick_callback(self._body_names[int(m.geom_bodyid[g])]))
            self._meshes.append(handle)
        self._link_bodies = sorted(
            {b for b in self._body_of if b in colors and colors[b] != BASE_COLOR}
        )
        self._link_labels = {
            b: scene.add_label(f"/names/{self._body_names[b]}", self._body_names[b], visible=False)
            for b in self._link_bodies
        }
        self._picked_label = scene.add_label("/picked", "", visible=False, font_screen_scale=1.2)

    def _build_markers(self, anchor: Array, axis: Array) -> None:
        """Joint frames and axes, contact markers, the tool, the ellipsoid, lost arrows, trail."""
        scene = self.server.scene
        self._frames = [
            scene.add_frame(f"/frames/{name}", axes_length=0.08, axes_radius=0.004, visible=False)
            for name in self.arm.joint_names
        ]
        self._axes = scene.add_arrows(
            "/joint_axes",
            self._axis_points(anchor, axis),
            (240, 160, 0),
            visible=False,
            **_AXIS_ARROWS,
        )
        self._contacts = [
            scene.add_icosphere(f"/contacts/c{k}", radius=0.012, color=(230, 30, 30), visible=False)
            for k in range(MAX_CONTACT_MARKERS)
        ]
        self._contact_labels = [
            scene.add_label(f"/contacts/name{k}", "", visible=False, anchor="bottom-left")
            for k in range(MAX_CONTACT_MARKERS)
        ]
        # The tool: a coordinate frame (unlike the red contact spheres) with its name.
        self._tool = scene.add_frame(
            "/tool",
            axes_length=0.07,
            axes_radius=0.005,
            origin_radius=0.012,
            origin_color=(250, 200, 0),
        )
        self._tool_label = scene.add_label(
            "/tool/name", f"tool ({self.arm.frame})", anchor="top-left"
        )
        self._ellipsoid = scene.add_icosphere(
            "/ellipsoid",
            radius=1.0,
            color=(40, 160, 220),
            opacity=0.3,
            subdivisions=3,
            scale=(1e-3, 1e-3, 1e-3),
            visible=False,
        )
        # The lost directions and the self-motion trail start hidden, with no segments.
        none = np.zeros((1, 2, 3))
        self._lost = scene.add_arrows("/lost", none, (200, 0, 200), visible=False, **_LOST_ARROWS)
        self._trail_handle = scene.add_line_segments(
            "/trail", none, (30, 100, 235), thickness=3.0, thickness_units="screen", visible=False
        )

    def _build_gizmo(self, site: Array, rot: Array) -> None:
        """The gizmo that drags the tool, at the tool's pose."""
        scene = self.server.scene
        self.gizmo = scene.add_transform_controls(
            "/gizmo",
            scale=max(0.15, 0.2 * self.reach),
            line_width=3.0,
            depth_test=False,
            position=tuple(site),
            wxyz=tuple(mat_to_quat(rot)),
        )
        self.gizmo.on_update(self._on_gizmo)

    def _reach(self) -> tuple[float, Array]:
        """Upper bound of the tool's distance from the first joint's anchor [m], and that anchor.

        The distance between consecutive joint anchors does not change with the joints (each
        anchor lies on its joint's axis), so their sum plus the last anchor's distance to the
        tool bounds the reach in every pose.
        """
        _, _, anchor, _, site, _ = self.sim.frames()
        pts = np.vstack([anchor, site])
        reach = float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=1)))
        return max(reach, 0.1), anchor[0].copy()

    def camera_view(self, view: str, aspect: float) -> tuple[Array, Array]:
        """Camera position and look-at point framing the arm's reach [m].

        The framed region is the half ball of radius `_reach` above the first joint's anchor;
        ``aspect`` (width / height of the view) narrows the horizontal field.
        """
        R = self.reach
        look = self.base + np.array([0.0, 0.0, 0.45 * R])
        radius = 0.8 * math.hypot(R, 0.55 * R)
        half = math.radians(45.0) / 2
        half = min(half, math.atan(math.tan(half) * max(aspect, 0.2)))
        dist = radius / math.sin(half)
        direction = {
            "front": (1.0, 0.0, 0.08),
            "side": (0.0, -1.0, 0.08),
            "top": (-0.02, 0.0, 1.0),
            "oblique": (0.75, -0.6, 0.35),
        }[view]
        d = np.array(direction) / np.linalg.norm(direction)
        return look + dist * d, look

    @staticmethod
    def _axis_points(anchor: Array, axis: Array, length: float = 0.16) -> Array:
        return np.stack([anchor - length * axis, anchor + length * axis], axis=1)

    def _pick_callback(self, name: str) -> Callable[[Any], None]:
        def on_click(_: Any) -> None:
            self._picked = name
            self.update(self.sim, force=True)

        return on_click

    # -- controls --------------------------------------------------------------------------
    def _build_gui(self, title: str, tab_title: str) -> None:
        gui = self.server.gui
        sim = self.sim
        gui.configure_theme(control_width="large", show_share_button=False)
        # viser has no call for the document's title: an image that fails to load sets it.
        js = html.escape(f"document.title={json.dumps(tab_title)}", quote=True)
        gui.add_html(f'<img src="/lab-title.invalid" alt="" style="display:none" onerror="{js}">')
        self.tab_title = tab_title
        gui.add_markdown(
            f"**{html.escape(title)}**  \n"
            f"PD with gravity compensation, every {1000 * sim.timestep:g} ms step:  \n"
            f"τ = qfrc_bias + kp (q* − q) − kd q̇, kp = {sim.kp:g} N m/rad"
        )
        self._build_joint_targets()
        self._build_redundancy()
        self._build_controller()
        self._build_push()
        self._build_session()
        self._build_view()
        self._build_plots()

    def _build_joint_targets(self) -> None:
        """The joint target sliders."""
        gui = self.server.gui
        sim = self.sim
        self.sliders = []
        with gui.add_folder("joint targets q*"):
            for i in range(self.arm.nq):
                s = gui.add_slider(
                    joint_label(self.arm, i),
                    min=float(sim.lower[i]),
                    max=float(sim.upper[i]),
                    step=0.01,
                    initial_value=float(np.clip(sim.home[i], sim.lower[i], sim.upper[i])),
                )
                s.on_update(self._target_callback(i))
                self.sliders.append(s)

    def _build_redundancy(self) -> None:
        """Self-motion, the gizmo and the velocity ellipsoid."""
        gui = self.server.gui
        with gui.add_folder("redundancy"):
            self.self_motion = gui.add_slider(
                SELF_MOTION_LABEL,
                min=-SELF_MOTION_RANGE,
                max=SELF_MOTION_RANGE,
                step=0.01,
                initial_value=0.0,
                hint="joint motion along the null space from the pose where you started: the "
                "tool stays put, the elbow moves",
            )
            self.self_motion.on_update(self._on_self_motion)
            self.show_gizmo = gui.add_checkbox(GIZMO_LABEL, True)
            self.show_gizmo.on_update(
                lambda _: self._set_visible(self.gizmo, self.show_gizmo.value)
            )
            self.show_ellipsoid = gui.add_checkbox(ELLIPSOID_LABEL, True)
            self.show_ellipsoid.on_update(lambda _: self.update(self.sim, force=True))

    def _build_controller(self) -> None:
        """kd, armature, contact forces and the nudge."""
        gui = self.server.gui
        sim = self.sim
        with gui.add_folder("controller and model"):
            self.kd = gui.add_slider(
                KD_LABEL,
                min=0.0,
                max=KD_MAX,
                step=0.01,
                initial_value=KD,
                marks=((0.0, "0"), (0.62, "0.62"), (2.0, "2"), (KD, f"{KD:g}")),
            )
            self.kd.on_update(lambda _: sim.set_kd(float(self.kd.value)))
            arm0 = sim.modelled_armature
            modelled = (
                f"{arm0[0]:g} kg m² ({ARMATURE_MODELLED})"
                if np.all(arm0 == arm0[0])
                else ARMATURE_MODELLED
            )
            self._armature_modelled = modelled
            self._armature_options = {modelled: None, ARMATURE_ZERO: 0.0}
            self.armature = gui.add_dropdown(
                ARMATURE_LABEL, tuple(self._armature_options), initial_value=modelled
            )
            self.armature.on_update(
                lambda _: sim.set_armature(self._armature_options[str(self.armature.value)])
            )
            self.collide = gui.add_checkbox(
                COLLIDE_LABEL,
                sim.contact_forces,
                hint="off: contacts are only reported and the links pass through each other",
            )
            self.collide.on_update(lambda _: sim.set_contact_forces(bool(self.collide.value)))
            self.nudge = gui.add_button(NUDGE_LABEL, hint="add 0.01 rad/s to every joint's speed")
            self.nudge.on_click(lambda _: sim.nudge())

    def _build_push(self) -> None:
        """The push sliders: a force at the tool."""
        gui = self.server.gui
        with gui.add_folder("push the tool"):
            self.push = [
                gui.add_slider(
                    label,
                    min=-PUSH_MAX,
                    max=PUSH_MAX,
                    step=0.5,
                    initial_value=0.0,
                    hint="a force at the tool, world axes: the plot below shows the joint "
                    "torque it makes and the momentum observer's estimate of it",
                )
                for label in PUSH_LABELS
            ]
            for slider in self.push:
                slider.on_update(lambda _: self._on_push())

    def _build_session(self) -> None:
        """Reset, pause, single step, speed and the CSV download."""
        gui = self.server.gui
        with gui.add_folder("session"):
            self.reset = gui.add_button(RESET_LABEL, hint="the keyframe at rest; settings kept")
            self.reset.on_click(lambda _: self._reset(all_settings=False))
            self.reset_all = gui.add_button(
                RESET_ALL_LABEL, hint="the keyframe, and kd, armature, contacts, speed as at start"
            )
            self.reset_all.on_click(lambda _: self._reset(all_settings=True))
            self.pause = gui.add_button(PAUSE_LABEL)
            self.pause.on_click(lambda _: self._toggle_pause())
            self.single = gui.add_button(STEP_LABEL, hint="pause, and take one timestep")
            self.single.on_click(lambda _: self._single_step())
            self.rate = gui.add_dropdown(
                RATE_LABEL, tuple(RATE_OPTIONS), initial_value=next(iter(RATE_OPTIONS))
            )
            self.rate.on_update(lambda _: self._set_rate())
            self.download = gui.add_button(CSV_LABEL)
            self.download.on_click(self._send_csv)

    def _build_view(self) -> None:
        """Camera views and what the scene shows."""
        gui = self.server.gui
        with gui.add_folder("view"):
            self.views = gui.add_button_group(VIEW_LABEL, VIEWS)
            self.views.on_click(lambda event: self.set_view(str(event.target.value)))
            self.show_names = gui.add_checkbox(NAMES_LABEL, False)
            self.show_frames = gui.add_checkbox("frames", False)
            self.show_axes = gui.add_checkbox("joint axes", False)
            self.show_contacts = gui.add_checkbox("contacts", True)
            self.show_trail = gui.add_checkbox("trail", True)
            for box in (
                self.show_names,
                self.show_frames,
                self.show_axes,
                self.show_contacts,
                self.show_trail,
            ):
                box.on_update(lambda _: self.update(self.sim, force=True))

    def _build_plots(self) -> None:
        """Readouts and plots in a panel of their own, docked left of the scene."""
        gui = self.server.gui
        sim = self.sim
        joint = sim.watch_joint
        limit = float(sim.effort_limit[sim.watch_index])
        panel = gui.add_panel()
        with panel.add_tab("readouts and plots"):
            self.readout_table = gui.add_html(self._readouts_html(sim.readouts()))
            self.speed_plot = self._live_plot(
                f"{joint} (rad/s)",
                "#d9480f",
                f"{joint} speed (rad/s), last {SPEED_WINDOW:g} s; "
                f"dashed: ±{REST_SPEED:g} (at rest)",
                speed_scales(2 * REST_SPEED),
                self._speed_axes(2 * REST_SPEED),
            )
            self.torque_plot = self._live_plot(
                f"{joint} (N m)",
                "#5f3dc4",
                f"{joint} motor torque (N m), last {SPEED_WINDOW:g} s; dashed: ±{limit:g} limit",
                {
                    "x": viser.uplot.Scale(time=False, auto=False, range=(-SPEED_WINDOW, 0.0)),
                    "y": viser.uplot.Scale(auto=False, range=(-1.25 * limit, 1.25 * limit)),
                },
                symmetric_axes(SPEED_WINDOW, limit, limit),
            )
            self._external_top = EXTERNAL_RANGE
            self.external_plot = self.server.gui.add_uplot(
                data=(np.zeros(0), np.zeros(0), np.zeros(0)),
                series=(
                    viser.uplot.Series(label="t − now (s)"),
                    viser.uplot.Series(label="estimate |r|", stroke="#2f9e44", width=1.5),
                    viser.uplot.Series(
                        label="push |Jᵀ F|", stroke="#495057", width=1, dash=(6.0, 4.0)
                    ),
                ),
                title=(
                    f"external joint torque (N m), last {SPEED_WINDOW:g} s: the momentum "
                    f"observer (gain {OBSERVER_GAIN:g}/s) from q, q̇ and the motors' torque; "
                    "dashed: the push's"
                ),
                scales=external_scales(EXTERNAL_RANGE),
                axes=(time_axis(SPEED_WINDOW), viser.uplot.Axis(size=48)),
                aspect=2.4,
            )
            # Up to the power of ten above twice the keyframe's sigma_min (1 for arm7's 0.23).
            s0 = float(sim.readouts().sigma_min)
            hi = 10.0 ** max(0, math.ceil(math.log10(max(2.0 * s0, 1e-9))))
            splits, labels = log_axis(SIGMA_FLOOR, hi)
            self._sigma_range = (SIGMA_FLOOR, 2.0 * hi)  # room for the top label
            self.sigma_plot = gui.add_uplot(
                data=(np.zeros(0), np.zeros(0)),
                series=(
                    viser.uplot.Series(label="t − now (s)"),
                    viser.uplot.Series(label="σ_min", stroke="#1c7ed6", width=1.5),
                ),
                title=(
                    f"σ_min of J (log), last {SIGMA_WINDOW:g} s; below {SIGMA_FLOOR:g} drawn at it"
                ),
                scales={
                    "x": viser.uplot.Scale(time=False, auto=False, range=(-SIGMA_WINDOW, 0.0)),
                    "y": viser.uplot.Scale(auto=False, distr=3, log=10, range=self._sigma_range),
                },
                axes=(
                    time_axis(SIGMA_WINDOW),
                    viser.uplot.Axis(splits=splits, values=labels, size=48),
                ),
                aspect=1.8,
            )
        panel.dock_left()
        panel.set_width(380)
        gui.main_panel.dock_right()

    # -- plot axes -------------------------------------------------------------------------
    def _live_plot(
        self,
        label: str,
        stroke: str,
        title: str,
        scales: dict[str, viser.uplot.Scale],
        axes: tuple[viser.uplot.Axis, ...],
    ) -> Any:
        """A joint's live series against time relative to now, empty until data arrives."""
        return self.server.gui.add_uplot(
            data=(np.zeros(0), np.zeros(0)),
            series=(
                viser.uplot.Series(label="t − now (s)"),
                viser.uplot.Series(label=label, stroke=stroke, width=1),
            ),
            title=title,
            scales=scales,
            axes=axes,
            aspect=2.4,
        )

    def _speed_axes(self, half: float) -> tuple[viser.uplot.Axis, ...]:
        return symmetric_axes(SPEED_WINDOW, half, REST_SPEED)

    # -- callbacks -------------------------------------------------------------------------
    def _target_callback(self, i: int) -> Callable[[Any], None]:
        name = self.arm.joint_names[i]

        def on_update(_: Any) -> None:
            if self._syncing:
                return
            self.sim.set_target(name, float(self.sliders[i].value))
            self._forget_anchor()
            self._sync_gizmo()

        return on_update

    def _on_push(self) -> None:
        if self._syncing:
            return
        self.sim.set_push([float(s.value) for s in self.push])

    def _sync_sliders(self, q: Array) -> None:
        """Show ``q`` on the joint sliders without acting on it."""
        with self._lock:
            self._syncing = True
            try:
                for i, s in enumerate(self.sliders):
                    s.value = float(
                        np.round(np.clip(q[i], self.sim.lower[i], self.sim.upper[i]), 4)
                    )
            finally:
                self._syncing = False

    def _forget_anchor(self) -> None:
        """A move other than the self-motion: the next self-motion starts where the arm is."""
        with self._lock:
            self._anchor = None
            self._self_motion_value = 0.0
            self._self_motion_q = None
            self._self_motion_text = ("-", "-")
            self._syncing = True
            try:
                self.self_motion.value = 0.0
            finally:
                self._syncing = False

    def _on_self_motion(self, _: Any) -> None:
        if self._syncing:
            return
        with self._lock:
            value = float(self.self_motion.value)
            if self._anchor is None or self._self_motion_q is None:
                self._anchor = self.sim.targets.copy()
                self._self_motion_value = 0.0
                self._self_motion_q = self._anchor[None]
            old, new = self._self_motion_value, value
            anchor, old_q = self._anchor, self._self_motion_q
            path = self.sim.self_motion_path(anchor, new) if new != 0 else None
            new_q = path.q if path is not None else anchor[None]
            # Back along the old path to the steps both share (all but a path's last step,
            # which may be shorter), then out along the new one.
            common = max(0, min(len(old_q), len(new_q)) - 2) if old * new > 0 else 0
            route = np.vstack([old_q[common:][::-1], new_q[common + 1 :]])
            self.sim.follow(route)
            self._self_motion_value, self._self_motion_q = new, new_q
            # |tool - tool at the anchor| at the path's end, as the path measured it.
            drift = float(path.position_drift[-1]) if path is not None else 0.0
            elbow = float(
                np.linalg.norm(self.sim.elbow_position(new_q[-1]) - self.sim.elbow_position(anchor))
            )
            stopped = f" ({path.stopped})" if path is not None and path.stopped else ""
            self._self_motion_text = (f"{drift:.2e}", f"{elbow:.4f}{stopped}")
            self._sync_sliders(new_q[-1])
            self._sync_gizmo(new_q[-1])

    def _on_gizmo(self, event: Any) -> None:
        phase = getattr(event, "phase", "update")
        with self._lock:
            if phase == "start" or self._drag_rest is None:
                self._dragging = True
                self._drag_rest = self.sim.targets.copy()
            target = np.asarray(self.gizmo.position, dtype=float)
            rot = quat_to_mat(self.gizmo.wxyz)
            q, err = solve_ik(self.arm, self.sim.targets, target, rot, rest=self._drag_rest)
            self.sim.set_targets(q)
            self._gizmo_target = target
            self._ik_error = err
            self._sync_sliders(q)
            if phase == "end":
                self._dragging = False
                self._drag_rest = None
            self._forget_anchor()

    def _sync_gizmo(self, q: Array | None = None) -> None:
        """Put the gizmo at the tool pose of the targets (unless it is being dragged)."""
        if self._dragging:
            return
        p, R = self.arm.site_pose(self.sim.targets if q is None else q)
        self.gizmo.position = tuple(p)
        self.gizmo.wxyz = tuple(mat_to_quat(R))

    @staticmethod
    def _set_visible(handle: Any, on: bool) -> None:
        if handle.visible != on:
            handle.visible = on

    def _reset(self, all_settings: bool) -> None:
        with self._lock:
            if all_settings:
                self.sim.reset_all()
                self._syncing = True
                try:
                    self.kd.value = float(self.sim.kd)
                    self.armature.value = self._armature_modelled
                    self.collide.value = bool(self.sim.contact_forces)
                    self.rate.value = next(iter(RATE_OPTIONS))
                    for slider in self.push:
                        slider.value = 0.0
                finally:
                    self._syncing = False
                if self.runner is not None:
                    self.runner.set_rate(1.0)
                    self.runner.paused = False
                    self.pause.label = PAUSE_LABEL
                self._picked = "-"
            else:
                self.sim.reset_pose()
            self._trail.clear()
            self._ik_error = None
            self._gizmo_target = None
            self._sync_sliders(self.sim.home)
            self._forget_anchor()
            self._sync_gizmo()
        self.update(self.sim, force=True)

    def _toggle_pause(self) -> None:
        if self.runner is None:
            return
        self.runner.paused = not self.runner.paused
        self.pause.label = RESUME_LABEL if self.runner.paused else PAUSE_LABEL

    def _single_step(self) -> None:
        if self.runner is None:
            return
        self.runner.step_once()
        self.pause.label = RESUME_LABEL

    def _set_rate(self) -> None:
        if self.runner is not None and not self._syncing:
            self.runner.set_rate(RATE_OPTIONS[str(self.rate.value)])

    def _send_csv(self, event: Any) -> None:
        name = self.arm.source.rsplit("/", 1)[-1].rsplit(".", 1)[0] or "arm"
        data = self.sim.csv().encode()
        client = getattr(event, "client", None)
        target = client if client is not None else self.server
        target.send_file_download(
            f"lab-{name}-t{self.sim.time:.3f}.csv", data, save_immediately=True
        )

    def set_view(self, view: str) -> None:
        """Point every connected browser's camera at the arm from ``view`` (see `VIEWS`)."""
        for client in self.server.get_clients().values():
            aspect = float(client.camera.aspect) if client.camera.aspect else 1.0
            position, look_at = self.camera_view(view, aspect)
            # (viser moves look_at along with position: position first, then look_at.)
            with client.atomic():
                client.camera.position = tuple(position)
                client.camera.look_at = tuple(look_at)

    # -- readouts --------------------------------------------------------------------------
    def _readouts_html(self, r: LabReadouts) -> str:
        j = r.watch_joint
        rtf = self.runner.real_time_factor if self.runner is not None else float("nan")
        rate = self.runner.rate if self.runner is not None else 1.0
        paused = self.runner is not None and self.runner.paused
        lost = "none"
        if r.lost.shape[1]:
            parts = []
            for u in r.lost.T:
                t, w = u[:3], u[3:]
                move = ", ".join(f"{x:.2f}" for x in t)
                turn = ", ".join(f"{x:.2f}" for x in w)
                parts.append(f"move ({move}) / turn ({turn})")
            lost = "; ".join(parts)
        values = {
            "sigma_min": f"{r.sigma_min:.4g}",
            "manipulability": f"{r.manipulability:.4g}",
            "contacts": r.contacts_text,
            "lost": lost,
            "speed": f"{r.watch_speed:.4g}",
            "peak": f"{r.watch_peak:.4g}",
            "torque": f"{r.watch_torque:.4g} (limit {r.watch_limit:g})",
            "contact_mass": "at rest" if np.isnan(r.contact_mass) else f"{r.contact_mass:.3g}",
            "ellipsoid": ", ".join(f"{s:.4f}" for s in r.velocity_semi_axes),
            "drift": self._self_motion_text[0],
            "elbow": self._self_motion_text[1],
            "ik": "-" if self._ik_error is None else f"{self._ik_error:.2e}",
            "picked": self._picked,
            "time": f"{r.time:.3f}" + (" (paused)" if paused else ""),
            "rtf": "-" if not np.isfinite(rtf) else f"{rtf:.2f} (set {rate:g})",
            "browsers": str(len(self.server.get_clients())),
        }
        rows = []
        for key, label in READOUT_KEYS.items():
            rows.append(
                f'<tr><td style="padding:2px 6px 2px 0;color:#666">'
                f"{html.escape(label.format(joint=j))}</td>"
                f'<td data-readout="{key}" style="padding:2px 0;font-family:monospace;'
                f'text-align:right;overflow-wrap:anywhere">{html.escape(values[key])}</td></tr>'
            )
        top = max(float(r.sigma[0]), 1e-12)
        bars = []
        for i, s in enumerate(r.sigma):
            width = 100.0 * float(s) / top
            color = "#e03131" if s < LOST_SIGMA else "#1c7ed6"
            bars.append(
                f'<tr><td style="color:#666;padding-right:6px">σ{i + 1}</td>'
                f'<td style="width:100%"><div data-sigma-bar="{i}" style="height:9px;'
                f'width:{width:.2f}%;background:{color}"></div></td>'
                f'<td data-sigma="{i}" style="font-family:monospace;text-align:right;'
                f'padding-left:6px">{s:.4g}</td></tr>'
            )
        return (
            '<div style="padding:0.25em 1.5em 0.25em 0.75em"><table class="lab-readouts" '
            'style="width:100%;font-size:0.8em;border-collapse:collapse">'
            + "".join(rows)
            + "</table>"
            '<div style="font-size:0.8em;margin-top:0.5em;color:#666">singular values of J '
            "(bars: share of σ1)</div>"
            '<table class="lab-sigma" style="width:100%;font-size:0.8em;border-collapse:collapse">'
            + "".join(bars)
            + "</table></div>"
        )

    # -- per frame ------------------------------------------------------------------------
    def plot_data(self, sim: LabSim) -> dict[str, tuple[Array, Array]]:
        """The plotted series, times relative to now [s] (see `LabSim.csv`)."""
        # One read of the time and the series: a step between separate reads put samples
        # after "now" (the browser test saw them right after a reset).
        now, (t, v), (_, tau), (ts, s) = sim.histories()
        later, (te, est), (_, true) = sim.external_torque_history()
        return {
            "speed": (t - now, v),
            "torque": (t - now, tau),
            "sigma": (ts - now, np.maximum(s, SIGMA_FLOOR)),
            "external": (te - later, est),
            "push": (te - later, true),
        }

    def update(self, sim: LabSim, force: bool = False) -> None:
        """Push the current state to the page (the runner's frame callback)."""
        with self._lock:
            self._frame += 1
            pos, quat, anchor, axis, site, rot = sim.frames()
            gpos, gquat = sim.geom_poses(self._geoms)
            q = sim.data.qpos.copy()
            moved = self._last_q is None or np.max(np.abs(q - self._last_q)) > 1e-9
            gui_due = force or self._frame % GUI_EVERY == 0
            readouts = sim.readouts() if gui_due or moved else None
            with self.server.atomic():
                if moved or force:
                    self._last_q = q
                    for h, p, w in zip(self._meshes, gpos, gquat, strict=True):
                        h.position = p
                        h.wxyz = w
                    self._tool.position = site
                    self._tool.wxyz = mat_to_quat(rot)
                    self._update_frames(pos, quat, anchor, axis)
                    self._update_trail(site)
                    self._update_names(gpos)
                if readouts is not None:
                    self._update_contacts(readouts)
                    self._update_tool_vectors(readouts, site)
                if gui_due and readouts is not None:
                    text = self._readouts_html(readouts)
                    if text != self._last_html:
                        self.readout_table.content = text
                        self._last_html = text
                    self._update_plots(sim)

    def _update_plots(self, sim: LabSim) -> None:
        data = self.plot_data(sim)
        v = data["speed"][1]
        half = nice_ceil(1.05 * float(np.max(np.abs(v))) if len(v) else 0.0, 2 * REST_SPEED)
        if half != self._speed_half:
            self._speed_half = half
            self.speed_plot.scales = speed_scales(half)
            self.speed_plot.axes = self._speed_axes(half)
        self.speed_plot.data = data["speed"]
        self.torque_plot.data = data["torque"]
        self.sigma_plot.data = data["sigma"]
        t, est = data["external"]
        true = data["push"][1]
        top = nice_ceil(max(np.max(est, initial=0.0), np.max(true, initial=0.0)), EXTERNAL_RANGE)
        if top != self._external_top:
            self._external_top = top
            self.external_plot.scales = external_scales(top)
        self.external_plot.data = (t, est, true)

    def _update_frames(self, pos: Array, quat: Array, anchor: Array, axis: Array) -> None:
        show = bool(self.show_frames.value)
        for h, p, w in zip(self._frames, pos, quat, strict=True):
            self._set_visible(h, show)
            if show:
                h.position = p
                h.wxyz = w
        show_axes = bool(self.show_axes.value)
        self._set_visible(self._axes, show_axes)
        if show_axes:
            self._axes.points = self._axis_points(anchor, axis)

    def _update_names(self, gpos: Array) -> None:
        show = bool(self.show_names.value)
        centres: dict[int, list[Array]] = {}
        for b, p in zip(self._body_of, gpos, strict=True):
            centres.setdefault(b, []).append(p)
        for b, label in self._link_labels.items():
            self._set_visible(label, show)
            if show:
                label.position = np.mean(centres[b], axis=0)
        picked = self._picked != "-"
        self._set_visible(self._picked_label, picked)
        if picked:
            body = next((b for b, n in self._body_names.items() if n == self._picked), None)
            if body in centres:
                self._picked_label.position = np.mean(centres[body], axis=0)
                self._picked_label.text = self._picked

    def _update_trail(self, site: Array) -> None:
        show = bool(self.show_trail.value)
        if not self._trail or np.linalg.norm(site - self._trail[-1]) > 1e-3:
            self._trail.append(site.copy())
            del self._trail[:-TRAIL_POINTS]
        visible = show and len(self._trail) >= 2
        if visible:
            pts = np.array(self._trail)
            self._trail_handle.points = np.stack([pts[:-1], pts[1:]], axis=1)
        self._set_visible(self._trail_handle, visible)

    def _update_tool_vectors(self, r: LabReadouts, site: Array) -> None:
        show = bool(self.show_ellipsoid.value)
        self._set_visible(self._ellipsoid, show)
        if show:
            self._ellipsoid.position = site
            self._ellipsoid.wxyz = mat_to_quat(r.velocity_axes)
            self._ellipsoid.scale = tuple(np.maximum(ELLIPSOID_SCALE * r.velocity_semi_axes, 1e-4))
        arrows = []
        for u in r.lost.T:
            for part in (u[:3], u[3:]):
                n = float(np.linalg.norm(part))
                if n > 0.2:
                    d = LOST_ARROW * part / n
                    arrows += [(site, site + d), (site, site - d)]
        if arrows:
            self._lost.points = np.array(arrows)
        self._set_visible(self._lost, bool(arrows))

    def _update_contacts(self, r: LabReadouts) -> None:
        show = bool(self.show_contacts.value)
        pts = r.contact_points[:MAX_CONTACT_MARKERS] if show else np.zeros((0, 3))
        for k, h in enumerate(self._contacts):
            on = k < len(pts)
            if on:
                h.position = pts[k]
            self._set_visible(h, on)
        # One name per pair in contact, at its first contact point.
        names = list(r.contact_pairs) if show else []
        for k, label in enumerate(self._contact_labels):
            on = k < len(names)
            if on:
                label.text = names[k]
                label.position = r.contact_pair_points[k]
            self._set_visible(label, on)
        # Links in contact: highlighted, and see-through so that the markers show.
        bodies = r.contact_bodies if show else frozenset()
        if bodies != self._highlighted:
            self._highlighted = bodies
            for b, h, color, g in zip(
                self._body_of, self._meshes, self._colors, self._geoms, strict=True
            ):
                hit = self._body_names[b] in bodies
                alpha = float(self.sim.model.geom_rgba[g, 3])
                h.color = CONTACT_COLOR if hit else color
                h.opacity = CONTACT_OPACITY * alpha if hit else (alpha if alpha < 1 else None)


class LabServer:
    """The lab: a `LabSim`, its real-time runner and its page on a viser server.

    Args:
        arm: The arm.
        host: Interface to listen on (loopback by default; the page has no authentication).
        port: TCP port (0: any free port; if taken, the next free one, with a warning).
        fps: Frames per second of the physics loop and the scene [1/s].
        verbose: Let viser print its banner and connection messages.
        warn: Where warnings go (a busy port, listening beyond loopback); default stderr.

    Raises:
        RedundancyError: Bad ``host`` or ``port``.

    Example:
        >>> with LabServer(arm, port=0) as lab:  # doctest: +SKIP
        ...     print(lab.url)
    """

    sim: LabSim
    server: Any
    runner: RealTimeRunner
    page: LabPage

    def __init__(
        self,
        arm: Arm,
        host: str = "127.0.0.1",
        port: int = 8080,
        fps: float = 30.0,
        verbose: bool = False,
        warn: Callable[[str], None] | None = None,
    ) -> None:
        check_address(host, port)
        self._warn = warn or (lambda msg: print(f"redundancy lab: warning: {msg}", file=sys.stderr))
        self.warnings: list[str] = []
        self.sim = LabSim(arm)
        self.host = host
        self.requested_port = port
        self.rejected_origins: list[str] = []
        # viser prints a banner whatever ``verbose`` says, with a loopback URL even for a
        # wildcard host: keep it off stdout unless asked; the lab prints the real URL.
        quiet = contextlib.nullcontext() if verbose else contextlib.redirect_stdout(io.StringIO())
        with quiet:
            self.server = viser.ViserServer(host=host, port=port, verbose=verbose)
        self._allowed_hosts = {"localhost", "127.0.0.1", "::1", "[::1]", host.lower()}
        if not is_loopback(host):
            self._allowed_hosts |= machine_names()
        self.server._websock_server.on_client_connect(self._check_origin)
        name = arm.source.rsplit("/", 1)[-1]
        title = f"Posing {name}: {arm.nq} joints, frame {arm.frame!r}"
        self.runner = RealTimeRunner(self.sim, fps=fps)
        self.page = LabPage(self.server, self.sim, self.runner, title, f"{name} · redundancy lab")
        self.runner.callbacks.append(self.page.update)
        self.runner.start()
        if port and self.port != port:
            self.warning(f"port {port} is taken; serving on port {self.port} instead")
        if not is_loopback(host):
            self.warning(
                f"listening on {host} beyond loopback: anyone who can reach this machine can "
                f"drive the lab (no authentication); open {self.url}"
            )

    def warning(self, msg: str) -> None:
        """Record and print a warning."""
        self.warnings.append(msg)
        self._warn(msg)

    async def _check_origin(self, conn: Any) -> None:
        """Close a websocket opened by a page from another origin (before any message).

        A browser sends ``Origin`` with every websocket; a page from another site (or a DNS
        rebinding of one) would otherwise drive the arm. Allowed: no Origin (not a browser),
        or an Origin equal to ``http://`` + the Host header whose host is an address literal
        or a name of this server (loopback names; with a wider host, the machine's names).
        Runs in the server's event loop before viser starts its message loops.
        """
        ws = self.server._websock_server
        connection = ws._live_connections.get(conn.client_id)
        if connection is None or connection.request is None:
            return
        headers = connection.request.headers
        origin = headers.get("Origin")
        if origin is None:
            return
        host_header = headers.get("Host", "")
        host_part = host_header.rsplit(":", 1)[0].lower() if host_header else ""
        if origin == f"http://{host_header}" and (
            host_part in self._allowed_hosts or is_ip(host_part)
        ):
            return
        self.rejected_origins.append(origin)

        async def closed(*_: Any, **__: Any) -> Any:
            import websockets.exceptions

            raise websockets.exceptions.ConnectionClosedOK(None, None)

        connection.recv = closed  # no message of this connection reaches viser
        await connection.close(1008, "origin not allowed")

    @property
    def port(self) -> int:
        """The port the server listens on."""
        return int(self.server.get_port())

    @property
    def url(self) -> str:
        """The page's address: for a wildcard host, this machine's name."""
        host = self.host
        if host in ("0.0.0.0", "::", ""):
            host = socket.gethostname()
        if ":" in host and not host.startswith("["):
            host = f"[{host}]"
        return f"http://{host}:{self.port}/"

    def stop(self) -> None:
        """Stop the physics thread and the server."""
        self.runner.stop()
        self.server.stop()

    def __enter__(self) -> LabServer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def serve_forever(self) -> None:
        """Block until Ctrl-C, reporting the first error of the physics loop, if any."""
        stop = threading.Event()
        reported = 0
        try:
            while not stop.wait(1.0):
                if len(self.runner.errors) > reported:
                    err = self.runner.errors[-1]
                    print(f"redundancy lab: error in the frame loop: {err!r}", file=sys.stderr)
                    reported = len(self.runner.errors)
        except KeyboardInterrupt:
            pass
        finally:
            self.stop()
