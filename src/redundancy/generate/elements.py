"""The elements of a random MJCF arm, each a hypothesis strategy.

Poses, geoms, inertials, joint attributes and default classes, in the units and forms the drawn
compiler settings say; `redundancy.generate` assembles them into whole models.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from hypothesis import strategies as st

#: Joint axes drawn as often as random directions: the coordinate axes, both ways.
AXES = ((1, 0, 0), (0, 1, 0), (0, 0, 1), (-1, 0, 0), (0, -1, 0), (0, 0, -1))


# -- number helpers ---------------------------------------------------------------------------


def num(x: float) -> str:
    """Shortest text that reads back as exactly ``x``."""
    return repr(float(x)) if x != int(x) else str(int(x))


def vec(xs: tuple[float, ...] | list[float] | np.ndarray) -> str:
    """Numbers as an MJCF attribute value (space-separated, each read back exactly)."""
    return " ".join(num(float(x)) for x in xs)


def real(lo: float, hi: float, digits: int = 3) -> st.SearchStrategy[float]:
    """Floats in [lo, hi] rounded to ``digits`` decimals (readable, shrink toward 0 or lo)."""
    return st.floats(lo, hi, allow_nan=False, allow_infinity=False).map(lambda x: round(x, digits))


def direction(min_norm: float = 0.2) -> st.SearchStrategy[tuple[float, float, float]]:
    """A coordinate axis or a rounded random vector of norm >= ``min_norm`` (not unit)."""
    rand = st.tuples(real(-1, 1, 2), real(-1, 1, 2), real(-1, 1, 2)).map(
        lambda v: v if math.hypot(*v) >= min_norm else (0.0, 0.0, 1.0)
    )
    return st.one_of(st.sampled_from(AXES), rand)


@dataclass
class Ctx:
    """What the drawn model's compiler settings are, while drawing its elements."""

    degree: bool
    features: set[str] = field(default_factory=set)

    def angle(self, rad: float) -> float:
        """An angle [rad] in the model's unit, rounded."""
        return round(math.degrees(rad), 3) if self.degree else round(rad, 5)


@st.composite
def orientation(draw: st.DrawFn, ctx: Ctx, forms: tuple[str, ...] | None = None) -> str:
    """One orientation attribute (or none) in any MJCF form."""
    form = draw(st.sampled_from(forms or ("none", "quat", "euler", "axisangle", "xyaxes", "zaxis")))
    if form == "none":
        return ""
    ctx.features.add(form)
    if form == "quat":
        q = draw(st.tuples(*[real(-1, 1, 3)] * 4))
        q = q if math.hypot(*q) >= 0.2 else (1.0, 0.0, 0.0, 0.0)
        return f' quat="{vec(q)}"'
    if form == "euler":
        a = draw(st.tuples(*[real(-math.pi, math.pi, 4)] * 3))
        return f' euler="{vec([ctx.angle(x) for x in a])}"'
    if form == "axisangle":
        v = np.array(draw(direction()), dtype=float)
        v /= np.linalg.norm(v)  # printed with repr: a unit axis to 1e-16
        ang = draw(real(-math.pi, math.pi, 4))
        return f' axisangle="{vec(v)} {num(ctx.angle(ang))}"'
    if form == "xyaxes":
        x = draw(direction())
        y = draw(direction())
        if np.linalg.norm(np.cross(x, y)) <= 0.2 * math.hypot(*x) * math.hypot(*y):
            y = (1, 0, 0) if abs(x[0]) < 0.5 * math.hypot(*x) else (0, 1, 0)
        return f' xyaxes="{vec(x)} {vec(y)}"'
    z = draw(direction())
    return f' zaxis="{vec(z)}"'


@st.composite
def pose(draw: st.DrawFn, ctx: Ctx, scale: float = 0.3) -> str:
    """A ``pos`` (within ``scale`` [m] per axis) and an orientation, each maybe absent."""
    pos = draw(st.one_of(st.none(), st.tuples(*[real(-scale, scale)] * 3)))
    text = f' pos="{vec(pos)}"' if pos is not None else ""
    return text + draw(orientation(ctx))


@st.composite
def geom(draw: st.DrawFn, ctx: Ctx, klass: str | None, visual: bool = False) -> str:
    """A primitive geom with mass, density or ``fromto``; ``visual``: no contact, no mass."""
    kind = draw(st.sampled_from(("sphere", "capsule", "cylinder", "box", "ellipsoid")))
    attrs = f'type="{kind}"'
    r = draw(real(0.01, 0.08))
    fromto = kind in ("capsule", "cylinder", "box") and draw(st.booleans())
    if fromto:
        ctx.features.add("fromto")
        a = draw(st.tuples(*[real(-0.2, 0.2)] * 3))
        b = draw(st.tuples(*[real(-0.2, 0.2)] * 3))
        b = b if math.dist(a, b) > 0.02 else (a[0], a[1], a[2] + 0.1)
        size = f"{num(r)}" if kind != "box" else f"{num(r)} {num(r * 0.7)}"
        attrs += f' size="{size}" fromto="{vec(a)} {vec(b)}"'
    else:
        if kind == "sphere":
            size = [r]
        elif kind in ("capsule", "cylinder"):
            size = [r, draw(real(0.01, 0.2))]
        else:
            size = draw(st.tuples(*[real(0.01, 0.1)] * 3))
        attrs += f' size="{vec(size)}"' + draw(pose(ctx, 0.15))
    if visual:
        ctx.features.add("visual geom")
        return f'<geom {attrs} contype="0" conaffinity="0" group="2" mass="0"/>'
    how = draw(st.sampled_from(("default", "mass", "density")))
    if how == "mass":
        attrs += f' mass="{num(draw(real(0.05, 3)))}"'
    elif how == "density":
        attrs += f' density="{num(draw(real(100, 3000, 0)))}"'
    if klass:
        attrs += f' class="{klass}"'
    ctx.features.add(f"geom {how}")
    return f"<geom {attrs}/>"


@st.composite
def inertial(draw: st.DrawFn, ctx: Ctx) -> str:
    """An explicit inertial of a solid box (so the moments are physical) [kg, kg m^2]."""
    m = draw(real(0.05, 3))
    dims = np.array(draw(st.tuples(*[real(0.02, 0.4)] * 3)))
    sq = dims**2
    diag = m / 12 * np.array([sq[1] + sq[2], sq[0] + sq[2], sq[0] + sq[1]])
    pos = draw(st.tuples(*[real(-0.2, 0.2)] * 3))
    if draw(st.booleans()):
        ctx.features.add("fullinertia")
        # A rotated box: R diag R^T, written as ixx iyy izz ixy ixz iyz.
        angles = draw(st.tuples(*[real(-math.pi, math.pi, 3)] * 3))
        R = rotation(angles)
        full = R @ np.diag(diag) @ R.T
        vals = [full[0, 0], full[1, 1], full[2, 2], full[0, 1], full[0, 2], full[1, 2]]
        return f'<inertial pos="{vec(pos)}" mass="{num(m)}" fullinertia="{vec(vals)}"/>'
    ctx.features.add("diaginertia")
    orient = draw(orientation(ctx, ("none", "quat", "euler", "zaxis")))
    return f'<inertial pos="{vec(pos)}"{orient} mass="{num(m)}" diaginertia="{vec(diag)}"/>'


def rotation(angles: tuple[float, float, float]) -> np.ndarray:
    """The rotation matrix Rz(c) Ry(b) Rx(a) of the angles (a, b, c) [rad]."""
    a, b, c = angles
    rx = np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])
    ry = np.array([[math.cos(b), 0, math.sin(b)], [0, 1, 0], [-math.sin(b), 0, math.cos(b)]])
    rz = np.array([[math.cos(c), -math.sin(c), 0], [math.sin(c), math.cos(c), 0], [0, 0, 1]])
    return rz @ ry @ rx


@st.composite
def joint_attrs(draw: st.DrawFn, ctx: Ctx, kind: str | None, in_default: bool = False) -> str:
    """Joint attributes other than name and class; ``kind`` None leaves the type to defaults.

    A joint ``pos`` is drawn only on joints, not in defaults (see
    `redundancy.generate.REFUSED_FEATURES`).
    """
    attrs = ""
    if kind is not None:
        attrs += f' type="{kind}"'
        ctx.features.add(kind)
    if draw(st.booleans()):
        attrs += f' axis="{vec(draw(direction()))}"'
    if not in_default and draw(st.booleans()):
        attrs += f' pos="{vec(draw(st.tuples(*[real(-0.1, 0.1)] * 3)))}"'
    if kind is not None and draw(st.booleans()):
        ctx.features.add("range")
        attrs += " " + joint_range(draw, ctx, kind)
    if draw(st.booleans()):
        attrs += f' armature="{num(draw(real(0, 0.1, 4)))}"'
    if draw(st.booleans()):
        attrs += f' damping="{num(draw(real(0, 2)))}"'
    return attrs


def joint_range(draw: st.DrawFn, ctx: Ctx, kind: str) -> str:
    """A ``range`` attribute: [m] for a slide, the model's angle unit for a hinge."""
    if kind == "slide":
        lo, hi = draw(real(-0.3, 0.0)), draw(real(0.01, 0.3))
        return f'range="{num(lo)} {num(hi)}"'
    lo, hi = draw(real(-math.pi, -0.05, 4)), draw(real(0.05, math.pi, 4))
    return f'range="{num(ctx.angle(lo))} {num(ctx.angle(hi))}"'


@st.composite
def defaults(draw: st.DrawFn, ctx: Ctx) -> tuple[str, dict[str, str], dict[str, str]]:
    """The ``<default>`` block, the joint type each class gives and each class's parent."""
    classes: dict[str, str] = {}
    parents: dict[str, str] = {}
    main = ""
    if draw(st.booleans()):
        armature, damping = num(draw(real(0, 0.05, 4))), num(draw(real(0, 1)))
        main += f'<joint armature="{armature}" damping="{damping}"/>'
    if draw(st.booleans()):
        main += f'<geom density="{num(draw(real(200, 2000, 0)))}"/>'
    names = draw(st.sampled_from(((), ("A",), ("A", "B"))))
    nested = len(names) == 2 and draw(st.booleans())
    blocks: dict[str, str] = {}
    for name in names:
        kind = draw(st.sampled_from(("hinge", "slide")))
        classes[name] = kind
        jattrs = f' type="{kind}"' + draw(joint_attrs(ctx, None, in_default=True))
        if draw(st.booleans()):
            jattrs += " " + joint_range(draw, ctx, kind)
        gattrs = ""
        if draw(st.booleans()):
            gattrs = f' density="{num(draw(real(200, 3000, 0)))}"'
        blocks[name] = f'<default class="{name}"><joint{jattrs}/><geom{gattrs}/>'
    if nested:
        ctx.features.add("nested classes")
        parents["B"] = "A"
        inner = f"\n    {blocks['A']}{blocks['B']}</default></default>"
    else:
        inner = "".join(f"\n    {b}</default>" for b in blocks.values())
    if main or inner:
        ctx.features.add("defaults")
    text = f"  <default>{main}{inner}\n  </default>\n" if (main or inner) else ""
    return text, classes, parents
