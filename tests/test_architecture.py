"""The architecture, checked from the source: engine calls live in the engine layer, and the
package import graph runs one way.

A new MuJoCo or Pinocchio call for kinematics or dynamics outside ``redundancy/engines`` fails
this test; the allow-list names each exception and why it is not an engine quantity.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "redundancy"

#: MuJoCo functions that compute kinematics, dynamics, simulation or contacts.
MUJOCO_COMPUTE = {
    "MjData",
    "mj_kinematics",
    "mj_comPos",
    "mj_comVel",
    "mj_crb",
    "mj_fullM",
    "mj_rne",
    "mj_jac",
    "mj_jacSite",
    "mj_jacBody",
    "mj_jacBodyCom",
    "mj_jacDot",
    "mj_forward",
    "mj_inverse",
    "mj_step",
    "mj_step1",
    "mj_step2",
    "mj_fwdPosition",
    "mj_fwdVelocity",
    "mj_collision",
    "mj_geomDistance",
    "mj_integratePos",
    "mj_mulM",
    "mj_solveM",
    "mj_factorM",
    "mj_energyPos",
    "mj_rnePostConstraint",
    "mj_jacSubtreeCom",
    "mj_angmomMat",
    "mj_subtreeVel",
    "mj_tendon",
    "mj_passive",
}

#: Pinocchio functions that compute kinematics or dynamics.
PINOCCHIO_COMPUTE = {
    "forwardKinematics",
    "framesForwardKinematics",
    "updateFramePlacement",
    "updateFramePlacements",
    "computeFrameJacobian",
    "computeJointJacobians",
    "computeJointJacobiansTimeVariation",
    "getFrameJacobian",
    "getFrameJacobianTimeVariation",
    "getJointJacobian",
    "crba",
    "rnea",
    "rneaInParallel",
    "aba",
    "nonLinearEffects",
    "computeGeneralizedGravity",
    "computeAllTerms",
    "integrate",
    "difference",
    "centerOfMass",
    "jacobianCenterOfMass",
    "computeDistances",
    "computeDistance",
    "computeCollisions",
    "updateGeometryPlacements",
    "computeCoriolisMatrix",
    "computeCentroidalMap",
}

#: Modules (relative to src/redundancy) allowed to make such calls, and why.
ALLOWED = {
    "engines/": "the engine layer: every kinematics and dynamics quantity",
    "collision/": "MuJoCo's narrow phase (mj_collision, mj_geomDistance) and coal's "
    "geometry placed by Pinocchio: the collision package's own engines",
}


def _modules() -> list[Path]:
    return sorted(p for p in SRC.rglob("*.py"))


def _rel(path: Path) -> str:
    return path.relative_to(SRC).as_posix()


def _allowed(rel: str) -> bool:
    return any(rel == key or (key.endswith("/") and rel.startswith(key)) for key in ALLOWED)


def engine_calls(path: Path) -> list[str]:
    """Calls of MuJoCo/Pinocchio compute functions and any coal call, as 'line: name'."""
    tree = ast.parse(path.read_text(), str(path))
    alias: dict[str, str] = {}  # local name -> library
    direct: dict[str, str] = {}  # from-imported function -> library
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for a in node.names:
                root = a.name.split(".")[0]
                if root in ("mujoco", "pinocchio", "coal"):
                    alias[a.asname or root] = root
        elif isinstance(node, ast.ImportFrom) and node.module:
            root = node.module.split(".")[0]
            if root in ("mujoco", "pinocchio", "coal") and node.level == 0:
                for a in node.names:
                    direct[a.asname or a.name] = root
    found = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        f = node.func
        lib = name = None
        if isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name):
            lib, name = alias.get(f.value.id), f.attr
        elif isinstance(f, ast.Name) and f.id in direct:
            lib, name = direct[f.id], f.id
        if lib == "mujoco" and name in MUJOCO_COMPUTE:
            found.append(f"{node.lineno}: mujoco.{name}")
        elif lib == "pinocchio" and name in PINOCCHIO_COMPUTE:
            found.append(f"{node.lineno}: pinocchio.{name}")
        elif lib == "coal":
            found.append(f"{node.lineno}: coal.{name}")
    return found


def test_engine_calls_only_in_the_engine_layer_and_the_allow_list() -> None:
    offenders = {
        _rel(p): calls for p in _modules() if not _allowed(_rel(p)) and (calls := engine_calls(p))
    }
    assert offenders == {}, (
        "MuJoCo/Pinocchio/coal calls outside the engine layer (use arm.mujoco / "
        f"arm.pinocchio / the collision package, or add to ALLOWED with a reason): {offenders}"
    )


def test_coal_only_in_the_collision_package() -> None:
    offenders = {
        _rel(p): [c for c in engine_calls(p) if "coal." in c]
        for p in _modules()
        if not _rel(p).startswith("collision/")
    }
    assert {k: v for k, v in offenders.items() if v} == {}


def test_the_scanner_sees_calls(tmp_path: Path) -> None:
    # The scanner itself must be able to fail: each spelling of an engine call is found.
    src = tmp_path / "m.py"
    src.write_text(
        "import mujoco\nimport pinocchio as pin\nfrom mujoco import mj_rne\nimport coal\n"
        "mujoco.mj_kinematics(m, d)\npin.crba(m, d, q)\nmj_rne(m, d, 0, t)\ncoal.Box(1, 1, 1)\n"
        "mujoco.mj_id2name(m, 1, 0)\n"
    )
    assert engine_calls(src) == [
        "5: mujoco.mj_kinematics",
        "6: pinocchio.crba",
        "7: mujoco.mj_rne",
        "8: coal.Box",
    ]


#: Layers, lowest first: a module may import only from its own layer or below.
LAYERS = [
    {"errors", "checks", "caching", "display", "kernels"},
    {"engines"},
    {"objectives"},  # what solve_ik and self_motion raise
    {"linalg", "inertia", "ik", "quantities"},
    {
        "arm",
        "arm_engines",
        "arm_keyframes",
        "arm_mass",
        "arm_coupled",
    },  # the Arm and the parts of its class
    {"model", "models"},
    {"collision"},
    {"analysis", "testing", "generate", "plotting"},
    {"lab"},  # simulation and controller (the lesson's holds use them), page, browser
    {"reports"},
    {"cli", "cli_io", "cli_audit", "__init__", "__main__"},
]


def _layer(top: str) -> int:
    for i, layer in enumerate(LAYERS):
        if top in layer:
            return i
    raise AssertionError(f"module {top!r} is in no layer of LAYERS")


def _top(rel: str) -> str:
    return rel.split("/")[0].removesuffix(".py")


def _imports(path: Path) -> set[str]:
    """Top-level redundancy modules a module imports (relative or absolute)."""
    tree = ast.parse(path.read_text(), str(path))
    pkg = _rel(path).split("/")[:-1]
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = pkg[: len(pkg) - (node.level - 1)] if node.level > 1 else pkg
                parts = base + (node.module.split(".") if node.module else [])
                if parts:
                    out.add(parts[0])
                else:  # from . import x (at the package root)
                    out.update(a.name for a in node.names)
            elif node.module and node.module.split(".")[0] == "redundancy":
                parts = node.module.split(".")
                out.add(parts[1] if len(parts) > 1 else node.names[0].name)
        elif isinstance(node, ast.Import):
            for a in node.names:
                parts = a.name.split(".")
                if parts[0] == "redundancy" and len(parts) > 1:
                    out.add(parts[1])
    return out


def test_import_graph_runs_one_way() -> None:
    upward = []
    for p in _modules():
        me = _top(_rel(p))
        for other in _imports(p) - {me}:
            if _layer(other) > _layer(me):
                upward.append(f"{_rel(p)} imports {other}")
    assert upward == []


@pytest.mark.parametrize("package", ["engines", "model", "collision", "analysis", "reports", "lab"])
def test_each_package_says_what_it_owns(package: str) -> None:
    doc = ast.get_docstring(ast.parse((SRC / package / "__init__.py").read_text()))
    assert doc and len(doc) > 40


#: The functions that may write an engine's per-thread pose key: the one loader of each
#: engine and the hand-over of the data to code that writes its own states.
KEY_WRITERS = {
    "engines/mujoco.py": {"__init__", "load", "forget", "stop"},
    "engines/pinocchio.py": {"__init__", "_load", "forget"},
    "engines/drake.py": {"__init__", "_load", "forget"},
}


def _key_writes(path: Path) -> set[str]:
    """Names of the functions that assign an attribute called ``key``."""
    tree = ast.parse(path.read_text(), str(path))
    found = set()
    for fn in ast.walk(tree):
        if isinstance(fn, ast.FunctionDef):
            for node in ast.walk(fn):
                targets = (
                    node.targets
                    if isinstance(node, ast.Assign)
                    else [node.target]
                    if isinstance(node, ast.AnnAssign | ast.AugAssign)
                    else []
                )
                for t in targets:
                    for el in t.elts if isinstance(t, ast.Tuple) else [t]:
                        if isinstance(el, ast.Attribute) and el.attr == "key":
                            found.add(fn.name)
    return found


def test_one_writer_of_each_engines_pose_key() -> None:
    writers = {_rel(p): _key_writes(p) for p in sorted((SRC / "engines").glob("*.py"))}
    assert {k: v for k, v in writers.items() if v} == KEY_WRITERS


# -- sizes a reader can hold, and no import cycles ----------------------------------------------

#: Modules longer than this many lines are listed in LONG_MODULES.
MODULE_LINES = 600
#: Functions of at least this many lines are listed in LONG_FUNCTIONS.
FUNCTION_LINES = 80
#: The modules still over `MODULE_LINES`: the list may only shrink, and holds at most 3.
LONG_MODULES = {
    "engines/mujoco.py",
    "lab/page.py",
}
#: The functions still of `FUNCTION_LINES` or more: the list may only shrink, and holds at
#: most 5.
LONG_FUNCTIONS: set[str] = set()


def module_sizes() -> dict[str, int]:
    """Lines per module of the library."""
    return {_rel(p): len(p.read_text().splitlines()) for p in _modules()}


def function_sizes() -> dict[str, int]:
    """Lines per function (methods and nested functions included), as 'module:name'."""
    out: dict[str, int] = {}
    for p in _modules():
        for node in ast.walk(ast.parse(p.read_text(), str(p))):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                key = f"{_rel(p)}:{node.name}"
                out[key] = max(out.get(key, 0), node.end_lineno - node.lineno + 1)  # type: ignore[operator]
    return out


def test_no_module_grows_past_the_size_a_reader_can_hold() -> None:
    long = {m for m, n in module_sizes().items() if n > MODULE_LINES}
    assert long - LONG_MODULES == set(), "split it at its seams"
    assert LONG_MODULES - long == set(), "shorter now: take it off LONG_MODULES"
    assert len(LONG_MODULES) <= 3


def test_no_function_grows_past_the_size_a_reader_can_hold() -> None:
    long = {f for f, n in function_sizes().items() if n >= FUNCTION_LINES}
    assert long - LONG_FUNCTIONS == set(), "break it at its natural seams"
    assert LONG_FUNCTIONS - long == set(), "shorter now: take it off LONG_FUNCTIONS"
    assert len(LONG_FUNCTIONS) <= 5


def _dotted(path: Path) -> str:
    """The module's dotted name, from its package ``redundancy`` down."""
    parts = list(path.with_suffix("").parts)
    parts = parts[len(parts) - 1 - parts[::-1].index("redundancy") :]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def module_imports(path: Path, known: set[str]) -> set[str]:
    """Library modules a module imports, at module or function level (``from . import x``
    counts as the submodule ``x`` when there is one)."""
    tree = ast.parse(path.read_text(), str(path))
    me = _dotted(path)
    package = me.split(".") if path.name == "__init__.py" else me.split(".")[:-1]
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - (node.level - 1)]
                module = ".".join(base + (node.module.split(".") if node.module else []))
            else:
                module = node.module or ""
            for a in node.names:
                if f"{module}.{a.name}" in known:
                    out.add(f"{module}.{a.name}")
                elif module in known:
                    out.add(module)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name in known)
    return out - {me}


def import_cycles(paths: list[Path]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    known = {_dotted(p) for p in paths}
    graph = {_dotted(p): module_imports(p, known) for p in paths}
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    cycles: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                cycles.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return cycles


def test_no_import_cycle_among_the_library_modules() -> None:
    assert import_cycles(_modules()) == []


def test_the_cycle_finder_sees_a_function_level_cycle(tmp_path: Path) -> None:
    # The finder itself must be able to fail: a function-level import closes a cycle.
    pkg = tmp_path / "redundancy"
    (pkg / "model").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "model" / "__init__.py").write_text("")
    (pkg / "model" / "ends.py").write_text("def f():\n    from .loading import g\n")
    (pkg / "model" / "loading.py").write_text("from .ends import f\n")
    assert import_cycles(sorted(pkg.rglob("*.py"))) == [
        ["redundancy.model.ends", "redundancy.model.loading"]
    ]
