"""The lab: lesson 5.2's interactive arm, served as a local web page with viser.

``redundancy lab [MODEL.xml]`` starts it. The page shows the arm drawn from its geoms, held by
:class:`redundancy.lab_sim.LabSim` (PD control with gravity compensation, stepped in real
time by :class:`redundancy.lab_sim.RealTimeRunner`), with sliders for the joint targets and
the controller's damping, a choice of armature, readouts and two live plots.

The page's state lives in the server: a browser that disconnects and reconnects (or a second
browser) gets the current scene, controls and plots, and the physics never waits for a
browser.

Readouts are rendered as an HTML table whose value cells carry ``data-readout`` attributes
(:data:`READOUT_KEYS`), so tests and scripts can read them from the DOM.
"""

from __future__ import annotations

import html
import sys
import threading
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np
from numpy.typing import NDArray

from ..arm import Arm
from ..errors import MissingDependencyError
from .sim import KD, SIGMA_WINDOW, SPEED_WINDOW, LabReadouts, LabSim, RealTimeRunner

try:
    import trimesh
    import viser
    import viser.uplot
except ImportError as _err:  # pragma: no cover - exercised only without the extra
    raise MissingDependencyError("viser", "lab") from _err

Array = NDArray[np.float64]

#: Label of the kd slider.
KD_LABEL = "kd (N m s/rad)"
#: Label of the armature choice.
ARMATURE_LABEL = "armature"
#: Choice meaning "the armature as modelled" / "no armature".
ARMATURE_MODELLED = "as modelled"
ARMATURE_ZERO = "0 (bare links)"
#: Buttons.
NUDGE_LABEL = "nudge"
RESET_LABEL = "reset to home"
#: Checkbox that turns contact forces on.
COLLIDE_LABEL = "links collide"
#: The readout cells' ``data-readout`` keys, with their row labels.
READOUT_KEYS = {
    "sigma_min": "σ_min of J",
    "manipulability": "manipulability",
    "contacts": "self-contacts",
    "speed": "{joint} speed (rad/s)",
    "peak": "{joint} |speed| peak, 0.2 s (rad/s)",
    "torque": "{joint} motor torque (N m)",
    "time": "simulated time (s)",
}
#: Trail of the tool site: this many positions, one per frame in which it moved by 1 mm.
TRAIL_POINTS = 300
#: Opacity of the links while they are in self-contact, so that the contact markers show.
CONTACT_OPACITY = 0.45
#: Contact markers drawn at most.
MAX_CONTACT_MARKERS = 24
#: Readouts and plots are refreshed every this many frames.
GUI_EVERY = 3


def joint_label(arm: Arm, i: int) -> str:
    """Label of joint ``i``'s slider, e.g. ``"j4 (rad)"``."""
    unit = "rad" if arm.joint_types[i] == "hinge" else "m"
    return f"{arm.joint_names[i]} ({unit})"


def _rgb(rgba: Array) -> tuple[int, int, int]:
    r, g, b = (round(255 * float(c)) for c in rgba[:3])
    return r, g, b


def _geom_mesh(model: mujoco.MjModel, g: int) -> trimesh.Trimesh | None:
    """A triangle mesh of a primitive geom in its own frame (None for planes and others)."""
    size = model.geom_size[g]
    kind = mujoco.mjtGeom(model.geom_type[g])
    if kind == mujoco.mjtGeom.mjGEOM_BOX:
        return trimesh.creation.box(extents=2 * size)
    if kind == mujoco.mjtGeom.mjGEOM_SPHERE:
        return trimesh.creation.icosphere(subdivisions=2, radius=size[0])
    if kind == mujoco.mjtGeom.mjGEOM_CAPSULE:
        return trimesh.creation.capsule(height=2 * size[1], radius=size[0], count=[24, 12])
    if kind == mujoco.mjtGeom.mjGEOM_CYLINDER:
        return trimesh.creation.cylinder(radius=size[0], height=2 * size[1], sections=32)
    if kind == mujoco.mjtGeom.mjGEOM_ELLIPSOID:
        mesh = trimesh.creation.icosphere(subdivisions=2, radius=1.0)
        mesh.apply_scale(size)
        return mesh
    return None


def drawn_geoms(model: mujoco.MjModel) -> list[int]:
    """Geoms to draw: the visual ones (no collision bits) if any, else every primitive geom."""
    primitive = [g for g in range(model.ngeom) if _geom_mesh(model, g) is not None]
    visual = [g for g in primitive if model.geom_contype[g] == 0 and model.geom_conaffinity[g] == 0]
    return visual or primitive


class LabPage:
    """The viser page of a :class:`LabSim`: scene, controls, readouts, plots.

    Args:
        server: The viser server to draw into.
        sim: The simulation to show and drive.
        title: Heading of the control panel.
    """

    def __init__(self, server: viser.ViserServer, sim: LabSim, title: str) -> None:
        self.server = server
        self.sim = sim
        self.arm = sim.arm
        self._frame = 0
        self._last_q: Array | None = None
        self._last_html = ""
        self._trail: list[Array] = []
        self._translucent = False
        self._lock = threading.Lock()
        self._build_scene()
        self._build_gui(title)
        self.update(sim, force=True)

    # -- scene -----------------------------------------------------------------------------
    def _build_scene(self) -> None:
        scene = self.server.scene
        m = self.sim.model
        scene.set_up_direction("+z")
        # Plain lights instead of viser's image-based environment: as clear, and several
        # times cheaper to render where WebGL runs in software (headless browsers, VMs).
        scene.configure_environment_map(None)
        scene.add_light_hemisphere(
            "/lights/sky", sky_color=(255, 255, 255), ground_color=(110, 110, 120), intensity=1.6
        )
        scene.add_grid("/floor", width=2.0, height=2.0, cell_size=0.1, section_size=0.5, plane="xy")
        self._geoms = drawn_geoms(m)
        self._meshes = []
        for g in self._geoms:
            mesh = _geom_mesh(m, g)
            assert mesh is not None
            rgba = m.geom_rgba[g]
            self._meshes.append(
                scene.add_mesh_simple(
                    f"/arm/geom{g}",
                    np.asarray(mesh.vertices, dtype=np.float32),
                    np.asarray(mesh.faces, dtype=np.uint32),
                    color=_rgb(rgba),
                    opacity=float(rgba[3]) if rgba[3] < 1 else None,
                )
            )
        _, _, anchor, axis, _ = self.sim.frames()
        self._frames = [
            scene.add_frame(f"/frames/{name}", axes_length=0.08, axes_radius=0.004, visible=False)
            for name in self.arm.joint_names
        ]
        self._axes = scene.add_arrows(
            "/joint_axes",
            self._axis_points(anchor, axis),
            (240, 160, 0),
            shaft_radius=0.003,
            head_radius=0.009,
            head_length=0.025,
            visible=False,
        )
        self._contacts = [
            scene.add_icosphere(f"/contacts/c{k}", radius=0.012, color=(230, 30, 30), visible=False)
            for k in range(MAX_CONTACT_MARKERS)
        ]
        self._site = scene.add_icosphere("/site", radius=0.012, color=(255, 60, 60))
        self._trail_handle = scene.add_line_segments(
            "/trail",
            np.zeros((1, 2, 3)),
            (30, 100, 235),
            thickness=3.0,
            thickness_units="screen",
            visible=False,
        )
        # A view from the side and above the arm, framing it at its keyframe.
        home_pos, *_ = self.sim.geom_poses(self._geoms)
        lo, hi = home_pos.min(axis=0), home_pos.max(axis=0)
        target = 0.5 * (lo + hi)
        reach = max(0.5, float(np.linalg.norm(hi - lo)))
        az, el = np.deg2rad(-60.0 + 180.0), np.deg2rad(15.0)
        offset = np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
        self.server.initial_camera.look_at = tuple(target)
        self.server.initial_camera.position = tuple(target + 3.0 * reach * offset)
        self.server.initial_camera.fov = np.deg2rad(45.0)

    @staticmethod
    def _axis_points(anchor: Array, axis: Array, length: float = 0.16) -> Array:
        return np.stack([anchor - length * axis, anchor + length * axis], axis=1)

    # -- controls --------------------------------------------------------------------------
    def _build_gui(self, title: str) -> None:
        gui = self.server.gui
        sim = self.sim
        gui.configure_theme(control_width="large", show_share_button=False)
        gui.add_markdown(
            f"**{html.escape(title)}**  \n"
            f"PD with gravity compensation, every {1000 * sim.timestep:g} ms step:  \n"
            f"τ = qfrc_bias + kp (q* − q) − kd q̇, kp = {sim.kp:g} N m/rad"
        )
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
        with gui.add_folder("controller and model"):
            self.kd = gui.add_slider(KD_LABEL, min=0.0, max=10.0, step=0.02, initial_value=KD)
            self.kd.on_update(lambda _: sim.set_kd(float(self.kd.value)))
            arm0 = sim.modelled_armature
            modelled = (
                f"{arm0[0]:g} kg m² ({ARMATURE_MODELLED})"
                if np.all(arm0 == arm0[0])
                else ARMATURE_MODELLED
            )
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
            self.reset = gui.add_button(RESET_LABEL)
            self.reset.on_click(lambda _: self._reset())
        with gui.add_folder("show"):
            self.show_frames = gui.add_checkbox("frames", False)
            self.show_axes = gui.add_checkbox("joint axes", False)
            self.show_contacts = gui.add_checkbox("contacts", True)
            self.show_trail = gui.add_checkbox("trail", True)
            for box in (self.show_frames, self.show_axes, self.show_contacts, self.show_trail):
                box.on_update(lambda _: self.update(self.sim, force=True))

        # Readouts and plots in a panel of their own, docked left of the scene.
        joint = sim.watch_joint
        panel = gui.add_panel()
        with panel.add_tab("readouts and plots"):
            self.readout_table = gui.add_html(self._readouts_html(sim.readouts()))
            t, v = sim.speed_history()
            self.speed_plot = gui.add_uplot(
                data=self._plot_data(t, v),
                series=(
                    viser.uplot.Series(label="t (s)"),
                    viser.uplot.Series(label=f"{joint} (rad/s)", stroke="#d9480f", width=1),
                ),
                title=f"{joint} speed (rad/s), last {SPEED_WINDOW:g} s",
                scales={"x": viser.uplot.Scale(time=False, auto=True)},
                aspect=2.0,
            )
            t, s = sim.sigma_history()
            self.sigma_plot = gui.add_uplot(
                data=self._plot_data(t, s),
                series=(
                    viser.uplot.Series(label="t (s)"),
                    viser.uplot.Series(label="σ_min", stroke="#1c7ed6", width=1.5),
                ),
                title=f"σ_min of J, last {SIGMA_WINDOW:g} s",
                scales={
                    "x": viser.uplot.Scale(time=False, auto=True),
                    "y": viser.uplot.Scale(auto=True),
                },
                aspect=2.0,
            )
        panel.dock_left()
        panel.set_width(360)
        gui.main_panel.dock_right()

    def _target_callback(self, i: int) -> Callable[[Any], None]:
        name = self.arm.joint_names[i]

        def on_update(_: Any) -> None:
            self.sim.set_target(name, float(self.sliders[i].value))

        return on_update

    def _reset(self) -> None:
        self.sim.reset()
        with self._lock:
            self._trail.clear()
        for i, s in enumerate(self.sliders):
            s.value = float(np.clip(self.sim.home[i], self.sim.lower[i], self.sim.upper[i]))

    @staticmethod
    def _plot_data(t: Array, v: Array) -> tuple[Array, Array]:
        if len(t) < 2:  # uPlot wants at least two points
            t0 = float(t[-1]) if len(t) else 0.0
            y0 = float(v[-1]) if len(v) else 0.0
            return np.array([t0 - 1e-3, t0]), np.array([y0, y0])
        return t, v

    def _readouts_html(self, r: LabReadouts) -> str:
        j = r.watch_joint
        values = {
            "sigma_min": f"{r.sigma_min:.4f}",
            "manipulability": f"{r.manipulability:.4f}",
            "contacts": r.contacts_text,
            "speed": f"{r.watch_speed:.3f}",
            "peak": f"{r.watch_peak:.3f}",
            "torque": f"{r.watch_torque:.2f} (limit {r.watch_limit:g})",
            "time": f"{r.time:.1f}",
        }
        rows = []
        for key, label in READOUT_KEYS.items():
            rows.append(
                f'<tr><td style="padding:2px 6px 2px 0;color:#666">'
                f"{html.escape(label.format(joint=j))}</td>"
                f'<td data-readout="{key}" style="padding:2px 0;font-family:monospace;'
                f'text-align:right;overflow-wrap:anywhere">{html.escape(values[key])}</td></tr>'
            )
        return (
            '<div style="padding:0.25em 1.5em 0.25em 0.75em"><table class="lab-readouts" '
            'style="width:100%;font-size:0.8em;border-collapse:collapse">'
            + "".join(rows)
            + "</table></div>"
        )

    # -- per frame ------------------------------------------------------------------------
    def update(self, sim: LabSim, force: bool = False) -> None:
        """Push the current state to the page (the runner's frame callback)."""
        with self._lock:
            self._frame += 1
            pos, quat, anchor, axis, site = sim.frames()
            gpos, gquat = sim.geom_poses(self._geoms)
            q = sim.data.qpos.copy()
            moved = self._last_q is None or np.max(np.abs(q - self._last_q)) > 1e-6
            gui_due = force or self._frame % GUI_EVERY == 0
            readouts = sim.readouts() if gui_due or moved else None
            with self.server.atomic():
                if moved or force:
                    self._last_q = q
                    for h, p, w in zip(self._meshes, gpos, gquat, strict=True):
                        h.position = p
                        h.wxyz = w
                    self._site.position = site
                    self._update_frames(pos, quat, anchor, axis, force)
                    self._update_trail(site, force)
                if readouts is not None:
                    self._update_contacts(readouts, force)
                if gui_due and readouts is not None:
                    text = self._readouts_html(readouts)
                    if text != self._last_html:
                        self.readout_table.content = text
                        self._last_html = text
                    self.speed_plot.data = self._plot_data(*sim.speed_history())
                    self.sigma_plot.data = self._plot_data(*sim.sigma_history())

    def _update_frames(
        self, pos: Array, quat: Array, anchor: Array, axis: Array, force: bool
    ) -> None:
        show = bool(self.show_frames.value) if hasattr(self, "show_frames") else False
        for h, p, w in zip(self._frames, pos, quat, strict=True):
            if h.visible != show:
                h.visible = show
            if show:
                h.position = p
                h.wxyz = w
        show_axes = bool(self.show_axes.value) if hasattr(self, "show_axes") else False
        if self._axes.visible != show_axes:
            self._axes.visible = show_axes
        if show_axes:
            self._axes.points = self._axis_points(anchor, axis)

    def _update_trail(self, site: Array, force: bool) -> None:
        show = bool(self.show_trail.value) if hasattr(self, "show_trail") else True
        if not self._trail or np.linalg.norm(site - self._trail[-1]) > 1e-3:
            self._trail.append(site.copy())
            del self._trail[:-TRAIL_POINTS]
        visible = show and len(self._trail) >= 2
        if visible:
            pts = np.array(self._trail)
            self._trail_handle.points = np.stack([pts[:-1], pts[1:]], axis=1)
        if self._trail_handle.visible != visible:
            self._trail_handle.visible = visible

    def _update_contacts(self, r: LabReadouts, force: bool) -> None:
        show = bool(self.show_contacts.value) if hasattr(self, "show_contacts") else True
        pts = r.contact_points[:MAX_CONTACT_MARKERS] if show else np.zeros((0, 3))
        for k, h in enumerate(self._contacts):
            on = k < len(pts)
            if on:
                h.position = pts[k]
            if h.visible != on:
                h.visible = on
        # Contact points lie inside both links: see through the links while there are any.
        translucent = len(pts) > 0
        if translucent != self._translucent:
            self._translucent = translucent
            for g, h in zip(self._geoms, self._meshes, strict=True):
                alpha = float(self.sim.model.geom_rgba[g, 3])
                h.opacity = (
                    CONTACT_OPACITY * alpha if translucent else (alpha if alpha < 1 else None)
                )


class LabServer:
    """The lab: a :class:`LabSim`, its real-time runner and its page on a viser server.

    Args:
        arm: The arm.
        host: Interface to listen on (loopback by default; the page has no authentication).
        port: TCP port (0: any free port; if taken, viser tries the next ones).
        fps: Frames per second of the physics loop and the scene [1/s].
        verbose: Let viser print its banner and connection messages.

    Example:
        >>> with LabServer(arm, port=0) as lab:  # doctest: +SKIP
        ...     print(lab.url)
    """

    def __init__(
        self,
        arm: Arm,
        host: str = "127.0.0.1",
        port: int = 8080,
        fps: float = 30.0,
        verbose: bool = False,
    ) -> None:
        self.sim = LabSim(arm)
        self.server = viser.ViserServer(host=host, port=port, verbose=verbose)
        self.host = host
        title = f"Posing {arm.source.rsplit('/', 1)[-1]}: {arm.nq} joints, site {arm.site!r}"
        self.page = LabPage(self.server, self.sim, title)
        self.runner = RealTimeRunner(self.sim, fps=fps)
        self.runner.callbacks.append(self.page.update)
        self.runner.start()

    @property
    def port(self) -> int:
        """The port the server listens on."""
        return int(self.server.get_port())

    @property
    def url(self) -> str:
        """The page's address."""
        host = "127.0.0.1" if self.host in ("0.0.0.0", "") else self.host
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


def serve(arm: Arm, host: str = "127.0.0.1", port: int = 8080) -> None:
    """Serve the lab for ``arm`` until Ctrl-C (the ``redundancy lab`` command).

    Args:
        arm: The arm.
        host: Interface to listen on (default: loopback only).
        port: TCP port.
    """
    lab = LabServer(arm, host=host, port=port)
    print(f"redundancy lab: {arm.source} at {lab.url} (Ctrl-C to stop)", flush=True)
    lab.serve_forever()
