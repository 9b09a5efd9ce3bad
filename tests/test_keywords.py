"""Keywords and lookups: every keyword the guide shows exists, and a wrong name is the library's
error naming the valid ones.

The guide's calls are read from its Python blocks and from the code in its prose (inline
```code``` spans such as ``batch.solve_ik(arm, targets, Q0, threads=k)``, which no test runs), each
resolved to the library's function (``rd.``, ``batch.``, names imported from ``redundancy``, and
methods of the library's classes on any other receiver) and held to its signature: an explicit
parameter, or a key of the ``TypedDict`` its ``**options: Unpack[...]`` declares.
"""

from __future__ import annotations

import ast
import importlib
import inspect
import pickle
import re
import typing
from collections.abc import Callable, Iterator
from pathlib import Path

import numpy as np
import pytest

import redundancy as rd
from redundancy import batch
from redundancy.quantities import QUANTITY

from .models import chain
from .test_readme import DOCUMENTS, ROOT, blocks

GUIDE = [p for p in DOCUMENTS if p.name == "README.md" or p.parent.name == "guide"]
#: Receivers that are modules: their attribute is the function.
MODULES = {
    "rd": rd,
    "redundancy": rd,
    "batch": batch,
    "collision": rd.collision,
    "selfmotion": rd.selfmotion,
}


def _public_classes() -> list[type]:
    """The classes the library exports (its methods are what a receiver such as ``arm.`` calls)."""
    found: dict[int, type] = {}
    names = ["redundancy.linalg", "redundancy.ik", "redundancy.objectives", "redundancy.testing"]
    modules = [*MODULES.values(), *(importlib.import_module(n) for n in names)]
    for module in modules:
        for attr in getattr(module, "__all__", dir(module)):
            value = getattr(module, attr, None)
            if inspect.isclass(value) and value.__module__.startswith("redundancy"):
                found[id(value)] = value
    return list(found.values())


CLASSES = _public_classes()


def _code(path: Path) -> Iterator[tuple[int, str]]:
    """(line, source) of each Python block and each inline code span of a document."""
    text = path.read_text()
    for b in blocks(text, path.name):
        if b.lang == "python":
            yield b.line, b.code
    in_block = False
    for n, line in enumerate(text.splitlines(), start=1):
        if line.startswith("```"):
            in_block = not in_block
            continue
        if not in_block:
            for span in re.findall(r"`([^`]+\([^`]*\))`", line):
                yield n, re.sub(r"=\s*(?=[,)])", "=...", span)  # `solve_ik(objective=)`


def _imports(path: Path) -> dict[str, object]:
    """Names a document's blocks import from the library (``from redundancy.x import y``)."""
    out: dict[str, object] = {}
    for _, source in _code(path):
        for node in ast.walk(_parsed(source) or ast.Module([], [])):
            if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("redundancy"):
                module = importlib.import_module(node.module or "")
                for alias in node.names:
                    if hasattr(module, alias.name):
                        out[alias.asname or alias.name] = getattr(module, alias.name)
    return out


def _targets(func: ast.expr, imported: dict[str, object]) -> list[Callable[..., object]]:
    """The library callables a call's function expression may name (empty: not the library's)."""
    if isinstance(func, ast.Name):  # imported by the document, or the package's own
        found = imported.get(func.id, getattr(rd, func.id, None))
        return [found] if callable(found) else []  # type: ignore[list-item]
    if not isinstance(func, ast.Attribute):
        return []
    chain_: list[str] = []
    node: ast.expr = func
    while isinstance(node, ast.Attribute):
        chain_.insert(0, node.attr)
        node = node.value
    if isinstance(node, ast.Name) and (node.id in MODULES or node.id in imported):
        value: object = MODULES.get(node.id) or imported[node.id]
        for attr in chain_:
            value = getattr(value, attr, None)
        return [value] if callable(value) else []  # type: ignore[list-item]
    if isinstance(node, ast.Name) and node.id in ("np", "plt", "os", "sys", "client", "pd"):
        return []
    # A method on a variable (arm., report., observer.): every library class that has it.
    return [getattr(c, func.attr) for c in CLASSES if callable(getattr(c, func.attr, None))]


def _keywords(fn: Callable[..., object]) -> set[str] | None:
    """The keywords ``fn`` takes; None: any (a plain ``**kwargs``)."""
    target = fn.__init__ if inspect.isclass(fn) else fn  # type: ignore[misc]
    try:
        params = inspect.signature(target).parameters
    except (TypeError, ValueError):
        return None
    names = {
        p.name
        for p in params.values()
        if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY) and p.name != "self"
    }
    for p in params.values():
        if p.kind is p.VAR_KEYWORD:
            hint = typing.get_type_hints(target, include_extras=True).get(p.name)
            if typing.get_origin(hint) is not typing.Unpack:
                return None
            (options,) = typing.get_args(hint)
            names |= set(typing.get_type_hints(options))
    return names


def _parsed(source: str) -> ast.Module | None:
    """A block or span as Python; a signature shown in prose (``f(a, *, b=1)``) as a call."""
    try:
        return ast.parse(source)
    except SyntaxError:
        pass
    head, _, args = source.partition("(")
    try:
        sig = ast.parse(f"def _({args[:-1]}): pass").body[0]
    except SyntaxError:
        return None
    assert isinstance(sig, ast.FunctionDef)
    named = [*sig.args.args[len(sig.args.args) - len(sig.args.defaults) :], *sig.args.kwonlyargs]
    keywords = ", ".join(f"{a.arg}=..." for a in named)
    return ast.parse(f"{head}({keywords})")


def _guide_calls() -> list[tuple[str, str, list[Callable[..., object]], tuple[str, ...]]]:
    """(where, call text, its library targets, its keywords) for every keyword call shown."""
    out = []
    for path in GUIDE:
        imported = _imports(path)
        for line, source in _code(path):
            tree = _parsed(source)
            assert tree is not None or "=" not in source, f"{path.name}:{line}: {source}"
            for node in ast.walk(tree or ast.Module([], [])):
                if not isinstance(node, ast.Call):
                    continue
                given = tuple(k.arg for k in node.keywords if k.arg is not None)
                targets = _targets(node.func, imported)
                if given and targets:
                    where = f"{path.relative_to(ROOT)}:{line + getattr(node, 'lineno', 1) - 1}"
                    out.append((where, ast.unparse(node)[:80], targets, given))
    return out


def test_every_keyword_the_guide_shows_exists() -> None:
    calls = _guide_calls()
    missing = []
    for where, text, targets, given in calls:
        for kw in given:
            takes = [_keywords(t) for t in targets]
            if not any(k is None or kw in k for k in takes):
                missing.append(f"{where}: {text} ({kw}=)")
    assert not missing, "\n".join(missing)
    # The reading found the guide's calls, the ones in prose included.
    texts = " ".join(t for _, t, _, _ in calls)
    assert len(calls) > 60
    assert "batch.solve_ik(arm, targets, Q0, threads=k)" in texts
    assert "rd.crosscheck_batch(..., threads=k)" in texts
    assert "arm.solve_ik(q0=..., objective=..., position_only=...)" in texts  # a signature


def test_the_reading_finds_a_keyword_the_library_lacks() -> None:
    """The check can fail: a misspelt keyword in a call is found."""
    (target,) = _targets(ast.parse("batch.jacobians(arm, Q, thread=2)").body[0].value.func, {})  # type: ignore[attr-defined]
    assert target is batch.jacobians
    keywords = _keywords(target)
    assert keywords is not None and "threads" in keywords and "thread" not in keywords


#: The guide (batch-and-clusters.md): "Every function of `redundancy.batch` ... takes
#: `executor=`", and its stacked functions `threads=` too.
BATCH_FUNCTIONS = sorted(
    n
    for n in batch.__all__
    if inspect.isfunction(getattr(batch, n)) and n not in ("map_chunks", "scatter", "poses")
)


@pytest.mark.parametrize("name", BATCH_FUNCTIONS)
def test_every_batch_function_takes_threads_and_executor(name: str) -> None:
    keywords = _keywords(getattr(batch, name))
    assert keywords is not None and {"threads", "executor"} <= keywords


def test_the_guide_says_every_batch_function_takes_executor() -> None:
    text = (ROOT / "docs" / "guide" / "batch-and-clusters.md").read_text()
    assert "Every function of `redundancy.batch` and `rd.crosscheck_batch` takes `executor=`" in (
        " ".join(text.split())
    )


# -- misspelt keywords --------------------------------------------------------------------------


@pytest.fixture(scope="module")
def arm() -> rd.Arm:
    return rd.load_string(chain(), frame="tip")


def test_a_misspelt_keyword_of_batch_solve_ik_names_the_valid_ones(arm: rd.Arm) -> None:
    goal = arm.site_pose([0.3, 0.2])
    with pytest.raises(
        rd.UnknownNameError,
        match=r"^unknown option 'thread'; valid option names: \['threads', 'executor'\]$",
    ):
        batch.solve_ik(arm, [goal], thread=2)  # type: ignore[call-arg]


def test_a_misspelt_keyword_of_external_torques_names_the_valid_ones(arm: rd.Arm) -> None:
    Q = np.zeros((2, 2))
    with pytest.raises(
        rd.UnknownNameError,
        match=r"^unknown option 'executer'; valid option names: \['threads', 'executor'\]$",
    ):
        batch.external_torques(arm, Q, Q, Q, 0.01, 5.0, executer=None)  # type: ignore[call-arg]


def test_batch_solve_ik_on_an_executor_equals_the_serial_results(arm: rd.Arm) -> None:
    from concurrent.futures import ThreadPoolExecutor

    goals = [arm.site_pose([x, -x]) for x in (0.1, 0.4, -0.3, 0.7, 1.0)]
    here = batch.solve_ik(arm, goals, position_only=True, threads=1)
    with ThreadPoolExecutor(2) as pool:
        there = batch.solve_ik(arm, goals, position_only=True, executor=pool)
    assert [r.q.tolist() for r in there] == [r.q.tolist() for r in here]
    assert all(r.success for r in there)


def test_external_torques_takes_threads(arm: rd.Arm) -> None:
    Q = np.array([[0.1, 0.0], [0.2, 0.1], [0.3, 0.4]])
    V, TAU = np.full((3, 2), 0.5), np.zeros((3, 2))
    one = batch.external_torques(arm, Q, V, TAU, 0.01, 5.0)
    two = batch.external_torques(arm, Q, V, TAU, 0.01, 5.0, threads=2)
    np.testing.assert_array_equal(one, two)


# -- lookups by name -------------------------------------------------------------------------------


def test_an_unknown_quantity_of_a_report_names_the_compared_ones(arm: rd.Arm) -> None:
    report = rd.crosscheck(arm, [0.3, 0.2], ["jacobian", "gravity"])
    assert report["gravity"].ok
    with pytest.raises(
        rd.UnknownNameError,
        match=r"^unknown compared quantity 'gravitee'; "
        r"valid compared quantity names: \['jacobian', 'gravity'\]$",
    ):
        report["gravitee"]
    with pytest.raises(KeyError):  # still a KeyError, as a mapping's lookup is
        report["gravitee"]


def test_the_registry_and_the_tolerances_name_their_quantities() -> None:
    valid = ", ".join(repr(n) for n in QUANTITY)
    for mapping in (QUANTITY, rd.TOLERANCES):
        with pytest.raises(rd.UnknownNameError) as info:
            mapping["gravitee"]
        assert str(info.value) == f"unknown quantity 'gravitee'; valid quantity names: [{valid}]"
        assert mapping == dict(mapping) and mapping.get("gravitee") is None
    assert pickle.loads(pickle.dumps(rd.TOLERANCES)) == rd.TOLERANCES


# The chain's two joints and a finger held at 0; keyframe "open" moves the finger.
KEYED = chain(
    body_extra='<body name="hand"><joint name="finger" type="slide" axis="1 0 0" '
    'range="0 0.04"/><geom type="sphere" size="0.02" mass="0.1"/></body>',
    extra='<keyframe><key name="home" qpos="0.5 0 0"/><key name="open" qpos="0 0 0.03"/></keyframe>',
)


def test_the_arms_mappings_name_their_keys() -> None:
    arm = rd.load_string(KEYED, frame="tip")
    cases = (
        (arm.held, "held joint", "'finger'"),
        (arm.keyframes, "arm keyframe", "'home'"),
        (arm.keyframe_moves("open"), "moved held joint", "'finger'"),
        (arm.frozen, "frozen joint", "none"),
    )
    for mapping, kind, valid in cases:
        with pytest.raises(rd.UnknownNameError) as info:
            mapping["nope"]
        assert str(info.value) == f"unknown {kind} 'nope'; valid {kind} names: [{valid}]"
    assert arm.held == {"finger": 0.0}
