"""Random MJCF arms for property tests: models nobody hand-tuned.

[`arms`][redundancy.generate.arms] draws fixed-base serial or branching arms with 1 to 9 hinge or
slide joints: arbitrary joint axes, body poses in every form MJCF allows (``pos``, ``quat``,
``euler``, ``axisangle``, ``xyaxes``, ``zaxis``), angles in radians or degrees, intrinsic euler
sequences, default classes and ``childclass``, primitive geoms with ``mass`` or ``density`` (or
``fromto``), explicit inertials (diagonal or full), armature, damping, joint ranges, actuators,
gravity and a site ``"tip"`` at the end of the last body. Every model it draws is one the loader
accepts (``strict=True``), so both engines must agree on it; a failing model shrinks to a small one.

`refused_arms` draws the same arms with one feature the loader must refuse (several
joints in one body, a tendon on an arm joint...), with the feature's name;
`resolved_arms` with one feature Pinocchio's parser reads differently (``<frame>``, an
extrinsic euler sequence...), which the loader serves through MuJoCo's compiled model.

Example:
    >>> from hypothesis import given
    >>> import redundancy as rd
    >>> from redundancy.generate import arms
    >>> @given(arms())
    ... def test_engines_agree(gen):
    ...     arm = rd.load_string(gen.xml, frame=gen.frame)
    ...     assert rd.compare_models(arm).equivalent
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import ClassVar

try:
    from hypothesis import strategies as st
except ImportError as _err:  # pragma: no cover - exercised only without the extra
    from ..errors import MissingDependencyError

    raise MissingDependencyError("hypothesis", "test") from _err

from ..checks import check_choice, check_count, check_flag
from ..errors import DeprecatedAlias, ParameterError
from . import elements as el

#: Intrinsic (lowercase) euler sequences MuJoCo accepts and Pinocchio reads the same way.
EULER_SEQUENCES = ("xyz", "zyx", "zxz", "xzx", "yzx", "xzy", "yxz", "zyz", "xyx", "yzy")

#:  Robot features off the arm that the loader holds or sets aside
#: ([`held_arms`][redundancy.generate.held_arms]): the arm is the chain to the tool, and these must
#: not change what the engines agree on.
HELD_FEATURES = (
    "several root bodies",
    "several kinematic trees",
    "ball joint",
    "free joint",
)

#:  Features [`refused_arms`][redundancy.generate.refused_arms] can add, each the ``feature`` of the
#: loader's refusal.
REFUSED_FEATURES = (
    "tendon on an arm joint",
    "tendon coupling on the arm",
    "unnamed joint",
    "no joints",
    "shell inertia",
)

#: Features Pinocchio's parser reads differently, for which the loader gives Pinocchio the
#: model as MuJoCo compiled it (`redundancy.model.resolved`); `resolved_arms` draws
#: one per model, and both engines must agree with MuJoCo's model of the file.
RESOLVED_FEATURES = (
    "extrinsic eulerseq",
    "axisangle with a non-unit axis",
    "<frame> element",
    "class inside a different childclass",
    "joint pos in a default class",
    "<replicate> element",
    "several joints in one body",
)

#:  Features Pinocchio's parser reads differently and the loader bridges:
#: [`arms`][redundancy.generate.arms] draws up to two of them per model, and both engines must still
#: agree.
BRIDGED_FEATURES = (
    "fixed root body with a pose",
    "mesh geom",
    "geom mass in a default class",
    "compiler boundmass",
    "compiler settotalmass",
)

#: What each refusal or bridged feature adds: (default classes, lines in the last body,
#: compiler attributes).
_REFUSAL_PARTS = {
    "class inside a different childclass": (
        '<default class="X"><joint damping="0.5"/></default>'
        '<default class="Y"><geom density="500"/>'
        "</default>",
        '<body name="extra" childclass="X"><geom type="sphere" size="0.02" class="Y"/></body>',
        "",
    ),
    "joint pos in a default class": (
        '<default class="P"><joint pos="0 0 0.01"/></default>',
        "",
        "",
    ),
    "geom mass in a default class": (
        '<default class="G"><geom mass="1"/></default>',
        '<body name="gm" pos="0 0.01 0" childclass="G"><geom type="sphere" size="0.02"/></body>',
        "",
    ),
    "compiler boundmass": ("", "", ' boundmass="0.01"'),
    "compiler settotalmass": ("", "", ' settotalmass="7"'),
    "<replicate> element": (
        "",
        '<replicate count="2" offset="0 0 0.05"><geom type="sphere" size="0.01"/></replicate>',
        "",
    ),
    "shell inertia": ("", '<geom type="sphere" size="0.02" shellinertia="true"/>', ""),
}


@dataclass(frozen=True)
class GeneratedArm:
    """One drawn MJCF model.

    Attributes:
        xml: The MJCF text.
        frame: Name of the tool frame, a site (``"tip"``).
        n_joints: Number of hinge and slide joints.
        features: Short names of the optional features the model uses.
        refused: For [`refused_arms`][redundancy.generate.refused_arms], the feature the loader must
            refuse, else None.
    """

    xml: str
    frame: str = "tip"
    n_joints: int = 0
    features: tuple[str, ...] = ()
    refused: str | None = None

    site: ClassVar[DeprecatedAlias] = DeprecatedAlias("frame")
    """Deprecated name of `frame` (warns with a DeprecationWarning)."""

    def __repr__(self) -> str:  # shown by hypothesis for a falsifying example
        head = f"GeneratedArm(n_joints={self.n_joints}, features={list(self.features)}"
        if self.refused:
            head += f", refused={self.refused!r}"
        return f"{head}, xml=\n{self.xml})"

    def _repr_pretty_(self, printer: object, cycle: bool) -> None:
        """Hypothesis's and IPython's pretty printer: the XML as text, not an escaped string."""
        printer.text(repr(self))  # type: ignore[attr-defined]


#: Refusals whose element sits on the tool's body, so the tool's body needs a joint on the arm.
_ON_THE_TOOL = (
    "tendon on an arm joint",
    "tendon coupling on the arm",
    "ball joint",
    "free joint",
    "several joints in one body",
    "unnamed joint",
    "shell inertia",
    *RESOLVED_FEATURES,
)


@dataclass
class _Head:
    """The drawn file's head (compiler, option, defaults) and what its bodies may use."""

    compiler: str
    option: str
    defaults: str
    classes: dict[str, str]
    class_parents: dict[str, str]
    extras: set[str]
    extra_lines: str

    def refining(self, active: str | None) -> list[str | None]:
        """Classes an element may name inside ``childclass=active``: it or its descendants."""
        if active is None:
            return [None, *self.classes]
        out: list[str | None] = [None]
        for c in self.classes:
            k: str | None = c
            while k is not None and k != active:
                k = self.class_parents.get(k)
            if k == active:
                out.append(c)
        return out


def _head(draw: st.DrawFn, ctx: el.Ctx, refuse: str | None) -> _Head:
    """Draw the compiler settings, gravity and defaults, and the bridged features to add."""
    seq = draw(st.sampled_from(EULER_SEQUENCES))
    if refuse == "extrinsic eulerseq":
        seq = seq.upper()
    extras = (
        {refuse}
        if refuse
        else draw(st.sets(st.sampled_from(BRIDGED_FEATURES), max_size=2))
        if draw(st.booleans())
        else set()
    )
    ctx.features.update(e for e in extras if e in BRIDGED_FEATURES)
    parts = [_REFUSAL_PARTS.get(e, ("", "", "")) for e in sorted(extras)]
    extra_defaults = "".join(p[0] for p in parts)
    extra_lines = "".join(p[1] for p in parts)
    extra_compiler = "".join(p[2] for p in parts)
    unit = "degree" if ctx.degree else "radian"
    compiler = f'<compiler angle="{unit}" autolimits="true" eulerseq="{seq}"{extra_compiler}/>'
    option = ""
    if draw(st.booleans()):
        ctx.features.add("gravity")
        option = f'\n  <option gravity="{el.vec(draw(st.tuples(*[el.real(-10, 10, 2)] * 3)))}"/>'
    defaults, classes, class_parents = draw(el.defaults(ctx))
    if extra_defaults:
        defaults = (
            defaults.replace("\n  </default>\n", f"\n    {extra_defaults}\n  </default>\n")
            if defaults
            else f"  <default>\n    {extra_defaults}\n  </default>\n"
        )
    return _Head(compiler, option, defaults, classes, class_parents, extras, extra_lines)


def _tree(
    draw: st.DrawFn,
    ctx: el.Ctx,
    max_joints: int,
    branching: bool,
    refuse: str | None,
    extras: set[str],
) -> tuple[list[bool], list[int], list[list[int]]]:
    """Draw the body tree: which bodies have a joint, each body's parent, each one's children.

    Jointed bodies, then up to two welded (joint-less) bodies inserted anywhere; the last body
    carries the tool.
    """
    jointed = [refuse != "no joints"] * draw(st.integers(1, max_joints))
    for _ in range(draw(st.integers(0, 2))):
        jointed.insert(draw(st.integers(0, len(jointed))), False)
    if refuse == "free joint":
        jointed[0] = True
    if refuse in ("ball joint", "free joint") and sum(jointed) < 2:
        jointed.append(True)  # the ball or free joint is held: the arm needs a hinge or slide
    if refuse in _ON_THE_TOOL:
        jointed[-1] = True  # the tool's body: its joint is on the arm (never "no joints")
    if "fixed root body with a pose" in extras:
        jointed[0] = False
        if not any(jointed):
            jointed.append(True)
    n = len(jointed)
    parents = [-1] + [
        (i - 1 - draw(st.integers(0, i - 1))) if branching else i - 1 for i in range(1, n)
    ]
    if any(p != i - 1 for i, p in enumerate(parents) if i):
        ctx.features.add("branching")
    chain, k = [], n - 1  # the tool's body and its ancestors: the arm
    while k >= 0:
        chain.append(k)
        k = parents[k]
    if refuse != "no joints" and not any(jointed[k] for k in chain):
        jointed[-1] = True  # a branch carried every joint: the tool's body gets one
    children: list[list[int]] = [[] for _ in range(n)]
    for i, p in enumerate(parents[1:], start=1):
        children[p].append(i)
    return jointed, parents, children


def _joint_lines(
    draw: st.DrawFn,
    ctx: el.Ctx,
    head: _Head,
    active: str | None,
    name: str,
    first: bool,
    refuse: str | None,
    on_tool: bool,
    root: bool,
) -> tuple[list[str], str]:
    """Draw a body's joint: its MJCF lines and its effective type (``hinge`` or ``slide``).

    ``active`` is the body's class in force, ``first`` whether no joint was drawn yet, ``on_tool``
    whether the body carries the tool, ``root`` whether it is the first body.
    """
    jclass = draw(st.sampled_from(head.refining(active)))
    in_force = jclass or active
    kind = (
        draw(st.sampled_from([None, "hinge", "slide"]))
        if in_force
        else draw(st.sampled_from(["hinge", "slide"]))
    )
    eff = kind or head.classes.get(in_force or "", "hinge")
    jattrs = draw(el.joint_attrs(ctx, kind))
    if jclass:
        jattrs += f' class="{jclass}"'
    if refuse == "unnamed joint" and on_tool:  # on the arm's chain
        lines = [f"<joint{jattrs}/>"]
    elif refuse == "ball joint" and first:
        lines = [f'<joint name="{name}" type="ball" limited="false"/>']
    elif refuse == "free joint" and root:
        lines = [f'<freejoint name="{name}"/>']
    else:
        lines = [f'<joint name="{name}"{jattrs}/>']
    if refuse == "several joints in one body" and on_tool:  # on the arm's chain
        lines.append(f'<joint name="{name}b" type="hinge" axis="1 0 0"/>')
    return lines, eff


def _geoms(
    draw: st.DrawFn, ctx: el.Ctx, head: _Head, active: str | None, refuse: str | None, on_tool: bool
) -> list[str]:
    """Draw a body's geoms (one, maybe a second), with the tool body's extra elements."""
    gclass = draw(st.sampled_from(head.refining(active)))
    geoms = [draw(el.geom(ctx, gclass))]
    if draw(st.booleans()):
        geoms.append(draw(el.geom(ctx, None, visual=draw(st.booleans()))))
    if refuse == "<frame> element" and on_tool:
        geoms.append('<frame pos="0 0 0.1"><geom type="sphere" size="0.02"/></frame>')
    if "mesh geom" in head.extras and on_tool:
        geoms.append('<geom type="mesh" mesh="cube" contype="0" conaffinity="0"/>')
    if head.extra_lines and on_tool:
        geoms.append(head.extra_lines)
    return geoms


def _tail(
    draw: st.DrawFn, ctx: el.Ctx, refuse: str | None, joint_names: list[str], extras: set[str]
) -> tuple[str, str]:
    """Draw the actuators, tendons and equalities after the world, and the mesh asset."""
    tail = ""
    if draw(st.booleans()) and joint_names and refuse is None:
        ctx.features.add("actuators")
        motors = []
        for name in draw(st.lists(st.sampled_from(joint_names), unique=True, min_size=1)):
            gear = el.num(draw(el.real(0.5, 100, 1)))
            lim = el.num(draw(el.real(1, 50, 1)))
            motors.append(f'<motor joint="{name}" gear="{gear}" ctrlrange="-{lim} {lim}"/>')
        tail += "  <actuator>" + "".join(motors) + "</actuator>\n"
    if refuse == "tendon on an arm joint":
        fixed = f'<fixed name="t"><joint joint="{joint_names[-1]}" coef="1"/></fixed>'
        tail += f"  <tendon>{fixed}</tendon>\n"
    if refuse == "tendon coupling on the arm":
        fixed = f'<fixed name="t"><joint joint="{joint_names[-1]}" coef="1"/></fixed>'
        tail += f'  <tendon>{fixed}</tendon><equality><tendon tendon1="t"/></equality>\n'
    asset = ""
    if "mesh geom" in extras:
        verts = "0 0 0 .1 0 0 0 .1 0 .1 .1 0 0 0 .1 .1 0 .1 0 .1 .1 .1 .1 .1"
        asset = f'  <asset><mesh name="cube" vertex="{verts}"/></asset>\n'
    return tail, asset


def _render(bodies: list[str], children: list[list[int]], i: int, depth: int) -> str:
    """Body ``i`` and its subtree as indented MJCF (each body's lines, then its children)."""
    pad = "  " * depth
    head, *rest = bodies[i].split("\n")
    out = [pad + head] + [pad + "  " + r for r in rest]
    out += [_render(bodies, children, c, depth + 1) for c in children[i]]
    out.append(pad + "</body>")
    return "\n".join(out)


@st.composite
def _model(draw: st.DrawFn, max_joints: int, branching: bool, refuse: str | None) -> GeneratedArm:
    ctx = el.Ctx(degree=draw(st.booleans()))
    head = _head(draw, ctx, refuse)
    extras = head.extras
    jointed, parents, children = _tree(draw, ctx, max_joints, branching, refuse, extras)
    n = len(jointed)
    class_names = list(head.classes)
    bodies: list[str] = []
    active_of: list[str | None] = []
    joint_names: list[str] = []
    joint_kinds: list[str] = []
    for i in range(n):
        on_tool = i == n - 1
        inherited = active_of[parents[i]] if i else None
        childclass = draw(st.sampled_from([None, *class_names])) if class_names else None
        active_of.append(childclass or inherited)
        attrs = f'name="b{i}"'
        if childclass:
            attrs += f' childclass="{childclass}"'
            ctx.features.add("childclass")
        if refuse == "axisangle with a non-unit axis" and on_tool:
            attrs += ' pos="0 0 0.1" axisangle="1 1 0 30"'
        elif i > 0 or jointed[0]:
            attrs += draw(el.pose(ctx))
        elif "fixed root body with a pose" in extras:
            attrs += ' pos="0 0 0.1" quat="0.9 0.1 0 0"'
        lines = [f"<body {attrs}>"]
        if jointed[i]:
            name = f"j{len(joint_names)}"
            joint, eff = _joint_lines(
                draw, ctx, head, active_of[i], name, not joint_names, refuse, on_tool, i == 0
            )
            lines += joint
            joint_names.append(name)
            joint_kinds.append(eff)
        if draw(st.booleans()):
            lines.append(draw(el.inertial(ctx)))
        lines += _geoms(draw, ctx, head, active_of[i], refuse, on_tool)
        if on_tool:
            lines.append(f'<site name="tip"{draw(el.pose(ctx, 0.2))}/>')
        bodies.append("\n".join(lines))

    world = _render(bodies, children, 0, 2)
    if refuse in ("several root bodies", "several kinematic trees"):
        joint = '<joint name="other" axis="0 0 1"/>' if refuse == "several kinematic trees" else ""
        world += (
            f'\n    <body name="other" pos="1 0 0">{joint}<geom type="sphere" size="0.05"/></body>'
        )
    tail, asset = _tail(draw, ctx, refuse, joint_names, extras)
    xml = (
        f"<mujoco>\n  {head.compiler}{head.option}\n{head.defaults}{asset}  <worldbody>\n"
        f"{world}\n  </worldbody>\n{tail}</mujoco>\n"
    )
    return GeneratedArm(xml, "tip", len(joint_names), tuple(sorted(ctx.features)), refuse)


def arms(max_joints: int = 9, branching: bool = True) -> st.SearchStrategy[GeneratedArm]:
    """Random MJCF arms the loader accepts and on which both engines must agree.

    Args:
        max_joints: Largest number of hinge and slide joints (an integer >= 1).
        branching: Also draw trees (bodies with several children), not only chains.

    Raises:
        ParameterError: ``max_joints`` not an integer >= 1, ``branching`` not a bool.
    """
    max_joints = check_count("max_joints", max_joints, 1)
    return _model(max_joints, check_flag("branching", branching), None)


def held_arms(
    features: tuple[str, ...] = HELD_FEATURES, max_joints: int = 4
) -> st.SearchStrategy[GeneratedArm]:
    """Random robots with one feature off the arm (see `HELD_FEATURES`); ``refused`` names it.

    Args:
        features: Which features to draw from (a nonempty subset of `HELD_FEATURES`).
        max_joints: Largest number of hinge and slide joints (an integer >= 1).

    Raises:
        UnknownNameError: A feature not in `HELD_FEATURES` (the message lists them).
        ParameterError: ``features`` not a nonempty collection of names, ``max_joints``
            not an integer >= 1.
    """
    return _one_feature("held feature", features, HELD_FEATURES, max_joints)


def refused_arms(
    features: tuple[str, ...] = REFUSED_FEATURES, max_joints: int = 4
) -> st.SearchStrategy[GeneratedArm]:
    """Random arms with one feature the loader refuses; ``refused`` names it.

    Arguments and errors as `held_arms`'s, ``features`` drawn from `REFUSED_FEATURES`.
    """
    return _one_feature("refused feature", features, REFUSED_FEATURES, max_joints)


def resolved_arms(
    features: tuple[str, ...] = RESOLVED_FEATURES, max_joints: int = 4
) -> st.SearchStrategy[GeneratedArm]:
    """Random arms with one feature Pinocchio's parser reads differently; ``refused`` names it.

    The loader serves such an arm through MuJoCo's compiled model. Arguments and errors as
    `held_arms`'s, ``features`` drawn from `RESOLVED_FEATURES`.
    """
    return _one_feature("resolved feature", features, RESOLVED_FEATURES, max_joints)


def _one_feature(
    kind: str, features: object, valid: tuple[str, ...], max_joints: object
) -> st.SearchStrategy[GeneratedArm]:
    """Trees of up to ``max_joints`` joints, each with one of ``features`` (``valid``'s)."""
    shown = f"a nonempty tuple of names from {list(valid)}"
    if isinstance(features, str | bytes) or not isinstance(features, Iterable):
        raise ParameterError("features", features, shown)
    chosen = tuple(features)
    if not chosen:
        raise ParameterError("features", features, shown)
    for f in chosen:
        check_choice(kind, f, valid)
    n = check_count("max_joints", max_joints, 1)
    return st.sampled_from(chosen).flatmap(lambda f: _model(n, True, f))


__all__ = [
    "BRIDGED_FEATURES",
    "EULER_SEQUENCES",
    "HELD_FEATURES",
    "REFUSED_FEATURES",
    "RESOLVED_FEATURES",
    "GeneratedArm",
    "arms",
    "held_arms",
    "refused_arms",
    "resolved_arms",
]
