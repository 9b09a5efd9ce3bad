"""URDF in both engines: Pinocchio's URDF parser and MuJoCo's URDF compiler.

Measured with MuJoCo 4.0 and Pinocchio 4.1 (``tests/test_urdf.py`` holds each case), the two
importers read the same numbers for link inertials, joint origins, axes, ranges, effort limits
(MuJoCo: ``actuatorfrcrange``), damping and friction (MuJoCo: ``frictionloss``). Where they
part, this module decides:

* **fixed links**: MuJoCo fuses them into their parent by default (a tool link then becomes a
  ``<frame>`` and its name is gone); the library compiles with ``fusestatic`` off, so every
  link stays a body and a tool link can carry the tool site (masses are unchanged: welded
  bodies move as one).
* **continuous joints**: Pinocchio makes them unbounded revolutes with two coordinates
  (cos, sin); the library rebuilds them as one-coordinate revolutes without limits, as
  MuJoCo's hinge (poses are sampled in [-pi, pi]).
* **mesh paths**: MuJoCo opens ``package://`` and ``file://`` names as plain paths and fails;
  the library resolves them (the URDF's directory and its parents, ``ROS_PACKAGE_PATH``) and
  gives MuJoCo absolute paths; an unresolved path is the library's error, naming it.
  Visual geoms are discarded (MuJoCo's default for URDF); Pinocchio's model reads no geometry.
* **missing inertials**: MuJoCo infers the mass of a link without ``<inertial>`` from its
  collision geoms (``inertiafromgeom`` auto), Pinocchio gives it none (URDF's meaning). The
  library compiles with ``inertiafromgeom`` false, so both read a missing inertial as no
  mass. A link the arm moves left with no mass at all (with the links fixed to it; the
  ROS-Industrial arms give none) gets a placeholder inertia so that MuJoCo compiles it, and
  the arm serves kinematics only: every dynamic quantity refuses, naming the links
  (`MissingInertiaError`). Off the arm, such a joint is held fixed.
* **mimic joints**: MuJoCo adds an equality constraint, Pinocchio ignores the mimic: set aside
  when the mimic couples held joints (a gripper's fingers), refused when it reaches an arm joint
  (`redundancy.model.robot`); a mimic on a fixed joint is nothing.
* **floating and planar joints**: a base of either is held where the file puts it (the arm
  starts at the link a planar one moves); a planar joint below a moving joint of the chain is
  refused (`urdf_tree.check_chain`).
* **armature**: URDF cannot express it; both engines read 0.
* **velocity limits**: Pinocchio reads them, MuJoCo drops them; the library uses neither.
* **self-collision**: URDF has no filter. MuJoCo's parent filter already skips a link and its
  parent, except where the parent is welded to the world; the library excludes every pair of links
  joined by a joint (with the links welded to each), the base included, plus the pairs of an SRDF's
  ``<disable_collisions>`` or a list given to [`redundancy.load`][redundancy.load].
"""

from __future__ import annotations

import os
import re
import xml.etree.ElementTree as ET
from collections.abc import Iterable, Sequence
from pathlib import Path

import mujoco
import numpy as np

from ..engines.mujoco import captured_warnings
from ..errors import ModelError, UnknownNameError
from .content import feed_assets, known_files, record
from .selection import MissingMesh, SetAside
from .urdf_inertia import prepare_urdf
from .urdf_pinocchio import build_pinocchio, continuous_joints
from .urdf_tree import UrdfTree, chain_joints, check_urdf, is_urdf, resolve_frame

# The tree's checks, the mended masses and Pinocchio's model live in modules of their own;
# their public names stay importable from here.
__all__ = [
    "DisabledPairs",
    "UrdfTree",
    "adjacent_pairs",
    "build_mujoco",
    "build_pinocchio",
    "chain_joints",
    "check_urdf",
    "continuous_joints",
    "find_mesh",
    "is_urdf",
    "prepare_urdf",
    "read_disabled_pairs",
    "resolve_frame",
    "resolve_mesh",
    "whole_robot_pairs",
]

DisabledPairs = str | os.PathLike[str] | Iterable[Sequence[str]]


def _package_dirs(base: Path) -> list[Path]:
    dirs = [base, *base.parents]
    for entry in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep):
        if entry:
            dirs.append(Path(entry))
    return dirs


def find_mesh(
    filename: str, base: Path, mujoco_dir: str | None = None, strip: bool = False
) -> tuple[Path | None, list[Path]]:
    """Where a URDF mesh file name is, and the places looked in.

    With the URDF's MuJoCo extension naming a ``meshdir`` (``<mujoco><compiler meshdir=...>``),
    MuJoCo's own place comes first: the name as written (its last part alone with
    ``strippath``) in ``meshdir``, counted from the URDF's directory, as MuJoCo compiles the
    file from disk. Then ``package://pkg/rest`` is looked up as
    ``pkg/rest`` in the URDF's directory, each of its parents and each ``ROS_PACKAGE_PATH``
    entry (and as ``rest`` in a directory named ``pkg`` among them); ``file://`` and plain
    relative names are taken from the URDF's directory.

    Returns:
        The file's absolute path (None: found nowhere), and every place looked in.
    """
    tried: list[Path] = []
    if mujoco_dir is not None:
        name = Path(filename.replace("\\", "/")).name if strip else filename
        if "://" not in name:  # MuJoCo opens "package://..." as a plain path and fails
            tried.append(base / mujoco_dir / name)
    if filename.startswith("package://"):
        rest = filename[len("package://") :]
        pkg, _, inner = rest.partition("/")
        for d in _package_dirs(base):
            tried += [d / rest, d / pkg / inner] + ([d / inner] if d.name == pkg else [])
        # Rebuilding a copy: the file the load found, carried by the recipe.
        tried += [Path(k) for k in known_files() if k.endswith("/" + rest)]
    else:
        name = filename[len("file://") :] if filename.startswith("file://") else filename
        tried.append(Path(name) if Path(name).is_absolute() else base / name)
    tried = list(dict.fromkeys(tried))
    found = next((t for t in tried if t.is_file()), None)
    return (None if found is None else Path(os.path.abspath(found))), tried


def resolve_mesh(filename: str, base: Path, source: str) -> Path:
    """Absolute path of a URDF mesh file name (see `find_mesh`).

    Raises:
        ModelError: No such file (the message names the mesh and where it was looked for).
    """
    found, tried = find_mesh(filename, base)
    if found is None:
        shown = ", ".join(str(t) for t in tried)
        raise ModelError(f"URDF {source}: mesh file {filename!r} not found (looked for: {shown})")
    return found


def read_disabled_pairs(
    pairs: DisabledPairs | None, tree: UrdfTree
) -> tuple[list[tuple[str, str]], SetAside | None]:
    """Link pairs that must never collide: an SRDF file's ``<disable_collisions>``, or pairs.

    An SRDF may describe a whole robot of which the URDF is a part (TALOS's SRDF for its
    left arm): its pairs naming a link the URDF does not have are skipped, and said so (see
    `whole_robot_pairs`). Listed pairs are this model's own: each link must exist.

    Args:
        pairs: Path of an SRDF file, or an iterable of (link, link) pairs, or None.
        tree: The URDF's tree (link names are checked against it).

    Returns:
        The pairs, and what was skipped of an SRDF's (None: nothing).

    Raises:
        ModelError: Unreadable SRDF, or a pair that is not two names.
        UnknownNameError: A listed pair's link the URDF does not have, or an SRDF none of
            whose pairs applies to this URDF (its first unknown link).
    """
    if pairs is None:
        return [], None
    out: list[tuple[str, str]] = []
    if isinstance(pairs, str | os.PathLike):
        p = Path(pairs)
        try:
            data = p.read_bytes()
            srdf = ET.fromstring(data)
        except (OSError, ET.ParseError) as err:
            raise ModelError(f"cannot read the SRDF file {str(p)!r}: {err}") from err
        record(p, data)
        for el in srdf.iter("disable_collisions"):
            out.append((el.get("link1", ""), el.get("link2", "")))
        return whole_robot_pairs(out, tree, p.name)
    else:
        for pair in pairs:
            if isinstance(pair, str) or len(pair) != 2:
                raise ModelError(f"a disabled collision pair is two link names, got {pair!r}")
            out.append((str(pair[0]), str(pair[1])))
    for a, b in out:
        for link in (a, b):
            if link not in tree.links:
                raise UnknownNameError("link", link, tree.links)
    return out, None


def whole_robot_pairs(
    pairs: list[tuple[str, str]], tree: UrdfTree, name: str
) -> tuple[list[tuple[str, str]], SetAside | None]:
    """An SRDF's pairs that apply to this URDF, and a note on those skipped.

    A pair naming a link the URDF does not have is another part of the robot's (the SRDF of
    a whole humanoid given with one arm's URDF): skipped, counted and named in the note. When
    no pair applies at all, the file is not this robot's, or its names are misspelt: the
    first unknown link is an error listing the valid names.

    Args:
        pairs: The SRDF's (link, link) pairs, in file order.
        tree: The URDF's tree.
        name: The SRDF file's name, for the note.

    Raises:
        UnknownNameError: No pair applies and a link is unknown.
    """
    known = set(tree.links)
    kept = [(a, b) for a, b in pairs if a in known and b in known]
    missing = sorted({link for pair in pairs for link in pair if link not in known})
    if not missing:
        return kept, None
    if not kept:
        raise UnknownNameError("link", missing[0], tree.links)
    shown = ", ".join(missing[:6]) + (f" and {len(missing) - 6} more" if len(missing) > 6 else "")
    note = SetAside(
        "SRDF pairs",
        name,
        f"{len(pairs) - len(kept)} of its {len(pairs)} pairs name links this URDF does not "
        f"have ({shown}): skipped, the {len(kept)} others applied",
    )
    return kept, note


def adjacent_pairs(tree: UrdfTree) -> list[tuple[str, str]]:
    """Pairs of links joined by a moving joint, each side with the links welded to it."""
    out = []
    for joint in tree.moving_joints:
        _, parent, child = tree.joints[joint]
        out += [(a, b) for a in sorted(tree.groups[parent]) for b in sorted(tree.groups[child])]
    return out


def build_mujoco(
    text: str,
    base: Path,
    source: str,
    tree: UrdfTree,
    tool_link: str,
    site: str,
    disabled: Sequence[tuple[str, str]],
    missing: list[MissingMesh],
) -> tuple[mujoco.MjSpec, mujoco.MjModel, list[SetAside]]:
    """Compile a URDF with MuJoCo, keeping fixed links as bodies, with a site on the tool link.

    A mesh found nowhere (see `find_mesh`) is left out with its geoms and added to
    ``missing``. Collada (``.dae``) and glTF (``.glb``, ``.gltf``) meshes, which MuJoCo has
    no decoder for, are read with trimesh and
    handed to MuJoCo as vertices and faces (coal then collides the same vertices); each is
    reported. Meshes whose volume MuJoCo finds too small to take an inertia from get
    ``inertia="shell"``: URDF inertials are explicit (``inertiafromgeom`` is off), so no
    mass comes from a mesh either way.

    Args:
        text: The URDF text.
        base: Directory relative mesh paths are taken from.
        source: File name or ``"<string>"``, for messages.
        tree: The URDF's tree (from `check_urdf`).
        tool_link: Link that carries the tool frame.
        site: Name of the site added at the tool link's origin.
        disabled: Extra link pairs excluded from collision.
        missing: Where the meshes found nowhere are listed (their geoms left out).

    Returns:
        An uncompiled copy of the spec (to hold joints in), its compiled model, and the notes
        on meshes.

    Raises:
        ModelError: MuJoCo cannot compile it (the message carries MuJoCo's).
    """
    try:
        with captured_warnings():
            spec = mujoco.MjSpec.from_string(text)
            # URDF keeps every link: the tool link must stay a body to carry the site, and
            # welded bodies change no mass, no inertia and no contact (weld groups are filtered).
            spec.compiler.fusestatic = False
            # A link without <inertial> has no mass in URDF (and in Pinocchio); MuJoCo's
            # default would infer one from the link's collision geoms.
            spec.compiler.inertiafromgeom = mujoco.mjtInertiaFromGeom.mjINERTIAFROMGEOM_FALSE
            notes = _resolve_meshes(spec, base, source, missing)
            _name_geoms(spec)
            body = spec.body(tool_link)
            if body is None:
                raise ModelError(f"URDF {source}: MuJoCo has no body for link {tool_link!r}")
            body.add_site(name=site)
            bodies = {b.name for b in spec.bodies}
            for a, b in dict.fromkeys([*adjacent_pairs(tree), *disabled]):
                if a in bodies and b in bodies and a != b:  # "world" is MuJoCo's world body
                    spec.add_exclude(bodyname1=a, bodyname2=b)
            # The spec is copied before it compiles: editing a compiled spec (deleting the
            # held joints) costs 50 ms a joint, a fresh copy 2 ms.
            try:
                return spec.copy(), spec.compile(), notes
            except ValueError as err:
                if "mesh volume is too small" not in str(err):
                    raise
                # Only the mesh's own inertia fails; with inertiafromgeom off it is unused.
                for mesh in spec.meshes:
                    mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL
                return spec.copy(), spec.compile(), notes
    except (ValueError, TypeError) as err:
        raise _compile_error(err, source) from err


#: Mesh formats MuJoCo has no decoder for, read with trimesh and given as vertices.
_TRIMESH_FORMATS = {".dae": "Collada", ".glb": "glTF", ".gltf": "glTF"}


def _resolve_meshes(
    spec: mujoco.MjSpec, base: Path, source: str, missing: list[MissingMesh]
) -> list[SetAside]:
    """Give MuJoCo each mesh by its absolute path, a Collada or glTF one as vertices.

    A mesh found nowhere is left out with the geoms that use it, and listed in ``missing``
    (meshes give collision geometry only: URDF inertials are explicit).
    """
    notes: list[SetAside] = []
    meshdir = _extension_meshdir(spec)
    for mesh in list(spec.meshes):
        path, tried = find_mesh(mesh.file, base, meshdir, bool(spec.strippath))
        if path is None:
            users = [g for g in spec.geoms if g.meshname == mesh.name]
            for link in dict.fromkeys(g.parent.name for g in users) or ("",):
                missing.append(MissingMesh(link, mesh.file, tuple(str(t) for t in tried)))
            for g in users:
                spec.delete(g)
            spec.delete(mesh)
            continue
        kind = _TRIMESH_FORMATS.get(path.suffix.lower())
        if kind is not None:
            record(path)
            _trimesh_mesh(mesh, path, kind, source)
            notes.append(
                SetAside(
                    f"{kind} mesh",
                    path.name,
                    "read with trimesh; MuJoCo and coal get the same vertices",
                    reaches_arm=True,
                )
            )
        else:
            mesh.file = str(path)
            feed_assets(spec, [path])
    return notes


def _extension_meshdir(spec: mujoco.MjSpec) -> str | None:
    """Where MuJoCo looks for meshes by the URDF's ``<mujoco><compiler>`` extension.

    None: the extension names neither ``meshdir`` nor ``strippath`` (MuJoCo would open the
    names as written, which a ``package://`` name is not).
    """
    return spec.meshdir if spec.meshdir or spec.strippath else None


def _compile_error(err: Exception, source: str) -> ModelError:
    """The library's error for MuJoCo's failure to read a URDF (an undecodable mesh named)."""
    found = re.search(r"no decoder found for mesh file '([^']+)'", str(err))
    if found:
        # Collada (.dae) collision meshes are common in ROS packages; MuJoCo reads STL, OBJ
        # and its own MSH.
        return ModelError(
            f"URDF {source}: MuJoCo cannot read the mesh {found.group(1)!r} (no decoder "
            f"for {Path(found.group(1)).suffix!r} files); give the collision geometry as "
            "STL or OBJ, or as primitives"
        )
    return ModelError(f"MuJoCo could not compile the URDF {source}: {err}")


def _trimesh_mesh(mesh: mujoco.MjsMesh, path: Path, kind: str, source: str) -> None:
    """Give MuJoCo a mesh's triangles as vertex data (MuJoCo cannot decode .dae, .glb, .gltf).

    A glTF scene's nodes are placed by their transforms and joined into one mesh.
    """
    import trimesh  # a dependency, imported on first use: most URDFs have STL meshes

    try:
        loaded = trimesh.load(str(path), force="mesh", process=False)
        vertices = np.asarray(loaded.vertices, dtype=float)
        faces = np.asarray(loaded.faces, dtype=int)
    except Exception as err:  # trimesh and its readers raise many kinds of errors
        shown = f"URDF {source}: cannot read the {kind} mesh {str(path)!r}"
        raise ModelError(f"{shown}: {err}") from err
    if len(vertices) < 4 or len(faces) == 0:
        raise ModelError(f"URDF {source}: the {kind} mesh {str(path)!r} has no triangles")
    mesh.file = ""
    mesh.uservert = vertices.ravel().tolist()
    mesh.userface = faces.ravel().tolist()


def _name_geoms(spec: mujoco.MjSpec) -> None:
    """Name MuJoCo's unnamed URDF geoms after their link, so reports can say which is which.

    A link's only collision geom takes the link's name; several take the names an unnamed MJCF geom
    gets ([`redundancy.model.names`][redundancy.model.names]): ``link geom 0``, ``link geom 1``...,
    by their index in the link, counted from 0 in file order (MuJoCo's URDF import leaves them
    unnamed; names already given are kept).
    """
    taken = {g.name for g in spec.geoms if g.name}
    for body in spec.bodies:
        unnamed = [(k, g) for k, g in enumerate(body.geoms) if not g.name]
        for k, geom in unnamed:
            name = body.name if len(body.geoms) == 1 else f"{body.name} geom {k}"
            while name in taken:
                name += "'"
            geom.name = name
            taken.add(name)
