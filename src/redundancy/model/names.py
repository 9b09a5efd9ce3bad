"""Display names of a model's bodies, geoms, joints and sites, named or not.

MJCF names are optional. Reports, collision pairs and errors need a name a reader can find
in the file, so an unnamed object is named by the body that holds it and its index among
that body's objects of its kind, counted from 0 in file order:

* a geom: ``"link3 geom 2"`` (the third geom of body ``link3``);
* a body: ``"link3 body 0"`` (the first child body of ``link3``);
* a joint or site: ``"link3 joint 0"``, ``"link3 site 1"``.

The holding body is itself named this way when it has no name (``"link3 body 0 geom 1"``);
the world body is ``"world"``. A generated name that an object of the same kind already
carries is followed by its id (``"link3 geom 2 (#17)"``), so display names are unique per
kind. Only MuJoCo's compiled model is read (names and tree arrays, no computation); the
names are computed on each call (linear in the objects), so hold the tuple when looping.
"""

from __future__ import annotations

import mujoco

from ..engines.mujoco import object_names

__all__ = ["body_name", "display_names", "geom_name", "joint_name", "site_name"]

_KINDS = {
    mujoco.mjtObj.mjOBJ_BODY: "body",
    mujoco.mjtObj.mjOBJ_GEOM: "geom",
    mujoco.mjtObj.mjOBJ_JOINT: "joint",
    mujoco.mjtObj.mjOBJ_SITE: "site",
}


def display_names(model: mujoco.MjModel, obj: mujoco.mjtObj) -> tuple[str, ...]:
    """Display names of every body, geom, joint or site of ``model``, by id.

    Args:
        model: MuJoCo's compiled model.
        obj: ``mjOBJ_BODY``, ``mjOBJ_GEOM``, ``mjOBJ_JOINT`` or ``mjOBJ_SITE``.

    Returns:
        One name per object, in id order; unique within the kind.

    Raises:
        KeyError: Another object type.
    """
    return _compute(model, _KINDS[obj])


def body_name(model: mujoco.MjModel, body: int) -> str:
    """Display name of one body (``"world"`` for body 0)."""
    return display_names(model, mujoco.mjtObj.mjOBJ_BODY)[body]


def geom_name(model: mujoco.MjModel, geom: int) -> str:
    """Display name of one geom, e.g. ``"link3 geom 2"`` when it has no name."""
    return display_names(model, mujoco.mjtObj.mjOBJ_GEOM)[geom]


def joint_name(model: mujoco.MjModel, joint: int) -> str:
    """Display name of one joint."""
    return display_names(model, mujoco.mjtObj.mjOBJ_JOINT)[joint]


def site_name(model: mujoco.MjModel, site: int) -> str:
    """Display name of one site."""
    return display_names(model, mujoco.mjtObj.mjOBJ_SITE)[site]


def _compute(model: mujoco.MjModel, kind: str) -> tuple[str, ...]:
    bodies = _body_names(model)
    if kind == "body":
        return tuple(bodies)
    obj, owner = {
        "geom": (mujoco.mjtObj.mjOBJ_GEOM, model.geom_bodyid),
        "joint": (mujoco.mjtObj.mjOBJ_JOINT, model.jnt_bodyid),
        "site": (mujoco.mjtObj.mjOBJ_SITE, model.site_bodyid),
    }[kind]
    raw = object_names(model, obj)
    seen_per_body: dict[int, int] = {}
    generated: list[str] = []
    for i in range(len(raw)):
        b = int(owner[i])
        k = seen_per_body.get(b, 0)
        seen_per_body[b] = k + 1
        generated.append(raw[i] or f"{bodies[b]} {kind} {k}")
    return _unique(raw, generated)


def _body_names(model: mujoco.MjModel) -> list[str]:
    raw = object_names(model, mujoco.mjtObj.mjOBJ_BODY)
    names = ["world"] + [""] * (model.nbody - 1)
    children: dict[int, int] = {}
    for b in range(1, model.nbody):  # parents come before children in MuJoCo's body order
        parent = int(model.body_parentid[b])
        k = children.get(parent, 0)
        children[parent] = k + 1
        names[b] = raw[b] or f"{names[parent]} body {k}"
    return list(_unique(raw, names))


def _unique(raw: list[str], names: list[str]) -> tuple[str, ...]:
    """Append ``(#id)`` to a generated name that clashes with another object's name."""
    taken = {n for n in raw if n}
    out = []
    for i, name in enumerate(names):
        if not raw[i] and name in taken:
            name = f"{name} (#{i})"
        out.append(name)
    return tuple(out)
