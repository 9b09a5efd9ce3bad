"""Fuzz: structured mutants of arm7.xml load into the library's error or into agreement.

Each mutant (attribute values, element order, ``<compiler>`` or ``<default>`` after
``<worldbody>``, a second ``<worldbody>``, reserved names, name clashes, encodings) is loaded
in a guarded worker process: an engine abort (a C++ assertion, heap corruption, a segfault)
kills the worker, not pytest, and fails the example with the mutant's text. In the worker a
mutant must either raise a :class:`redundancy.RedundancyError` or load; a loaded one must be
usable, and when its equivalence report shows no difference the engines must agree at the
zero pose and at a bent pose (never agreement reported between two different arms), for
masses, inertias and offsets below :data:`PLAUSIBLE`.

Budget: 30 examples by default (a few seconds), 400 under ``HYPOTHESIS_PROFILE=redundancy-thorough``.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import xml.etree.ElementTree as ET
from collections import Counter
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import redundancy as rd

from .test_bad_input import ENGINE_NOISE

ARM7 = rd.model_path("arm7").read_text()
SRC = Path(rd.__file__).resolve().parent.parent
EXAMPLES = 400 if settings().max_examples >= 1000 else 30
#: The settings of the three fuzz tests below.
FUZZ_SETTINGS = settings(
    max_examples=EXAMPLES,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)
#: Largest mass [kg], inertia [kg m^2] or offset [m] at which agreement is required. Beyond
#: it (a mutant with a 1e300 kg link) rounding noise of order 1e-16 x the largest entry
#: exceeds the cross-check's per-element tolerance 1e-9 x max(1, |value|) on entries that are
#: near zero: the cross-check then reports disagreement (never a false agreement).
PLAUSIBLE = 1e6
#: Outcomes of the fuzz run, printed at the end (``pytest -s``).
STATS: Counter[str] = Counter()

#: The worker: reads one request per line (JSON: file path and site), loads the file, prints
#: one ``RESULT <json>`` line. Anything else it prints (engine noise) is ignored.
WORKER = r"""
import json, os, sys, tempfile, traceback
import numpy as np
import redundancy as rd

results = os.fdopen(int(os.environ["FUZZ_RESULT_FD"]), "w")  # stdout, stderr: the engines'
for line in sys.stdin:
    req = json.loads(line)
    out = {}
    noise = tempfile.TemporaryFile()
    saved = os.dup(1), os.dup(2)
    os.dup2(noise.fileno(), 1)
    os.dup2(noise.fileno(), 2)
    try:
        arm = rd.load(req["path"], frame=req["site"], strict=req["strict"])
    except rd.RedundancyError as err:
        out = {"status": "refused", "message": str(err)}
    except BaseException as err:
        out = {"status": "raw", "message": "".join(traceback.format_exception(err))}
    else:
        try:
            report = rd.compare_models(arm)
            qs = np.vstack([np.zeros(arm.nq), np.clip(np.full(arm.nq, 0.4), arm.lower, arm.upper)])
            cc = rd.crosscheck(arm, qs)
            finite = all(np.isfinite(a.max_error) for a in cc.agreements)
            m = arm.mj_model
            scale = float(max(m.body_mass.max(), m.body_inertia.max(), np.abs(m.body_pos).max()))
            out = {
                "scale": scale,
                "status": "loaded",
                "equivalent": report.equivalent,
                "agree": cc.ok,
                "finite": finite,
                "lines": report.lines() + cc.lines(),
            }
        except rd.RedundancyError as err:
            out = {"status": "refused after loading", "message": str(err)}
        except BaseException as err:
            out = {"status": "raw", "message": "".join(traceback.format_exception(err))}
    sys.stdout.flush()
    sys.stderr.flush()
    os.dup2(saved[0], 1)
    os.dup2(saved[1], 2)
    os.close(saved[0])
    os.close(saved[1])
    noise.seek(0)
    out["printed"] = noise.read().decode("utf-8", "replace")
    noise.close()
    results.write(json.dumps(out) + "\n")
    results.flush()
"""


class Worker:
    """One long-lived Python process that loads models; restarted after it dies."""

    def __init__(self, script: str = WORKER) -> None:
        self.script = script
        self.proc: subprocess.Popen[str] | None = None
        self.results: object = None

    def _start(self) -> subprocess.Popen[str]:
        read, write = os.pipe()
        env = dict(
            os.environ,
            PYTHONPATH=str(SRC) + os.pathsep + os.environ.get("PYTHONPATH", ""),
            FUZZ_RESULT_FD=str(write),
        )
        proc = subprocess.Popen(
            [sys.executable, "-c", self.script],
            stdin=subprocess.PIPE,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            text=True,
            env=env,
            pass_fds=(write,),
        )
        os.close(write)
        self.results = os.fdopen(read, "r")
        return proc

    def load(self, path: Path, frame: str = "ee", strict: bool = True) -> dict[str, object]:
        if self.proc is None or self.proc.poll() is not None:
            self.proc = self._start()
        assert self.proc.stdin
        self.proc.stdin.write(
            json.dumps({"path": str(path), "site": frame, "strict": strict}) + "\n"
        )
        self.proc.stdin.flush()
        line = self.results.readline()
        if line:
            return json.loads(line)
        code = self.proc.wait()
        self.proc = None
        self.results.close()
        return {"status": "crashed", "message": f"worker exited with {code}"}

    def close(self) -> None:
        if self.proc is not None and self.proc.poll() is None:
            assert self.proc.stdin
            self.proc.stdin.close()
            self.proc.wait(timeout=30)


@pytest.fixture(scope="module")
def worker() -> object:
    w = Worker()
    yield w
    w.close()


# ------------------------------------------------------------------------------------------
# Mutations
# ------------------------------------------------------------------------------------------

NAMED = ("body", "joint", "site", "geom")
VALUES = st.one_of(
    st.sampled_from(
        [
            "nan",
            "inf",
            "-inf",
            "-1",
            "0",
            "1e300",
            "-1e-300",
            "",
            "x",
            "1 2",
            "1 2 3 4 5 6 7",
            "0 0 0",
            "true",
            "false",
            "auto",
            "universe",
            "é",
            "1e308 1e308 1e308",
        ]
    ),
    st.floats(-1e3, 1e3, allow_nan=False).map(repr),
    st.lists(st.floats(-10, 10, allow_nan=False), min_size=1, max_size=4).map(
        lambda xs: " ".join(f"{x:g}" for x in xs)
    ),
)
ENCODINGS = ("utf-16", "latin-1", "utf-8-sig", "utf-8")
RESERVED = ("universe", "root_joint", "world", "link3_fixed", "ee_fixed", "j1Bis")


def _elements(root: ET.Element) -> list[ET.Element]:
    return [el for el in root.iter() if el is not root]


@st.composite
def mutants(draw: st.DrawFn) -> tuple[bytes, str]:
    """A mutant of arm7.xml as bytes, and a description of what was done."""
    root = ET.fromstring(ARM7)
    done: list[str] = []
    encoding = "utf-8"
    for _ in range(draw(st.integers(1, 3))):
        kind = draw(
            st.sampled_from(
                [
                    "attribute",
                    "order",
                    "compiler after worldbody",
                    "default after worldbody",
                    "second worldbody",
                    "reserved name",
                    "name clash",
                    "encoding",
                    "drop element",
                ]
            )
        )
        els = _elements(root)
        if not els:
            break
        if kind == "attribute":
            el = draw(st.sampled_from(els))
            attrs = sorted(el.attrib) or ["pos"]
            attr = draw(st.sampled_from(attrs))
            value = draw(VALUES)
            el.set(attr, value)
            done.append(f"<{el.tag}> {attr}={value!r}")
        elif kind == "order":
            parents = [e for e in root.iter() if len(e) > 1]
            if not parents:
                continue
            parent = draw(st.sampled_from(parents))
            children = list(parent)
            order = draw(st.permutations(range(len(children))))
            for c in children:
                parent.remove(c)
            for i in order:
                parent.append(children[i])
            done.append(f"children of <{parent.tag}> reordered {list(order)}")
        elif kind in ("compiler after worldbody", "default after worldbody"):
            tag = kind.split()[0]
            for el in root.findall(tag):
                root.remove(el)
                root.append(el)
            done.append(kind)
        elif kind == "second worldbody":
            extra = ET.SubElement(root, "worldbody")
            what = draw(st.sampled_from(["geom", "site", "body", "copy"]))
            if what == "geom":
                ET.SubElement(extra, "geom", size="0.05", pos="1 0 0")
            elif what == "site":
                ET.SubElement(extra, "site", name="extra_site", pos="1 0 0")
            elif what == "body":
                body = ET.SubElement(extra, "body", name="extra_body", pos="1 0 0")
                ET.SubElement(body, "geom", size="0.05")
            else:
                first = root.find("worldbody")
                assert first is not None
                extra.extend(ET.fromstring(ET.tostring(first)))
            done.append(f"second worldbody with {what}")
        elif kind == "reserved name":
            named = [e for e in els if e.tag in NAMED and e.get("name")]
            if not named:
                continue
            el = draw(st.sampled_from(named))
            name = draw(st.sampled_from(RESERVED))
            done.append(f"<{el.tag} name={el.get('name')!r}> renamed {name!r}")
            el.set("name", name)
        elif kind == "name clash":
            named = [e for e in els if e.tag in NAMED and e.get("name")]
            if not named:
                continue
            a, b = draw(st.sampled_from(named)), draw(st.sampled_from(named))
            done.append(
                f"<{a.tag} name={a.get('name')!r}> renamed like <{b.tag}> {b.get('name')!r}"
            )
            a.set("name", b.get("name", ""))
        elif kind == "encoding":
            encoding = draw(st.sampled_from(ENCODINGS))
            named = [e for e in els if e.tag in ("body", "geom") and e.get("name")]
            if named:
                el = draw(st.sampled_from(named))
                el.set("name", el.get("name", "") + "é")
            done.append(f"encoded {encoding}" + (", a name made non-ASCII" if named else ""))
        else:
            parents = [e for e in root.iter() if len(e)]
            if not parents:
                continue
            parent = draw(st.sampled_from(parents))
            child = draw(st.sampled_from(list(parent)))
            parent.remove(child)
            done.append(f"<{child.tag}> removed from <{parent.tag}>")
    text = ET.tostring(root, encoding="unicode")
    if encoding == "utf-8":
        data = text.encode()
    else:
        declared = (
            "utf-16" if encoding == "utf-16" else "ISO-8859-1" if encoding == "latin-1" else "utf-8"
        )
        data = f'<?xml version="1.0" encoding="{declared}"?>\n{text}'.encode(encoding)
    return data, "; ".join(done)


@FUZZ_SETTINGS
@given(mutant=mutants())
def test_fuzzed_arm7(mutant: tuple[bytes, str], worker: Worker, tmp_path_factory) -> None:
    _check(mutant, worker, tmp_path_factory, strict=True)


def _check(mutant: tuple[bytes, str], worker: Worker, tmp_path_factory, strict: bool) -> None:
    """The library's error, or a usable arm that agrees wherever its models are equivalent."""
    data, what = mutant
    path = tmp_path_factory.mktemp("fuzz") / "arm7.xml"
    path.write_bytes(data)
    result = worker.load(path, strict=strict)
    status = result["status"]
    STATS[status if status != "loaded" else f"loaded, equivalent={result['equivalent']}"] += 1
    assert status in ("refused", "loaded"), f"{what}: {status}\n{result.get('message')}"
    assert not ENGINE_NOISE.search(str(result["printed"])), f"{what}: {result['printed']}"
    if status == "refused":
        assert result["message"], what
    elif result["equivalent"] and result["finite"] and result["scale"] < PLAUSIBLE:
        assert result["agree"], f"{what}:\n" + "\n".join(result["lines"])  # type: ignore[arg-type]


# ------------------------------------------------------------------------------------------
# Text mutants (moved from test_bad_input.py, where they ran in the pytest process)
# ------------------------------------------------------------------------------------------

TOKENS = [
    '"', "<", ">", "/>", "</body>", "<body>", '<joint name="x"/>', ' bogus="1"', "nan", "inf",
    "-1", "0", "1e308", "-1e-308", "<frame>", '<include file="x.xml"/>', "&amp;", "\x00",
    '<joint type="ball" name="y"/>', '<geom size="0"/>', "ü", " ", "\n", "</worldbody><worldbody>",
    '<joint name="universe"/>', '<site name="link1"/>',
]  # fmt: skip
NUMBER = re.compile(r"-?\d+\.?\d*(?:e-?\d+)?")


@st.composite
def text_mutants(draw: st.DrawFn) -> tuple[bytes, str]:
    """arm7.xml's text with 1-3 deletions, insertions, duplications, truncations or numbers."""
    text = ARM7
    done = []
    for _ in range(draw(st.integers(1, 3))):
        n = len(text)
        kind = draw(st.sampled_from(["delete", "insert", "number", "duplicate", "truncate"]))
        i = draw(st.integers(0, n))
        if kind == "delete":
            k = draw(st.integers(1, 200))
            text = text[:i] + text[i + k :]
            done.append(f"deleted {k} characters at {i}")
        elif kind == "insert":
            token = draw(st.sampled_from(TOKENS))
            text = text[:i] + token + text[i:]
            done.append(f"inserted {token!r} at {i}")
        elif kind == "duplicate":
            j = min(n, i + draw(st.integers(1, 400)))
            text = text[:j] + text[i:j] + text[j:]
            done.append(f"duplicated {i}..{j}")
        elif kind == "truncate":
            text = text[:i]
            done.append(f"truncated at {i}")
        else:
            spans = [m.span() for m in NUMBER.finditer(text)] or [(0, 0)]
            a, b = spans[draw(st.integers(0, len(spans) - 1))]
            new = draw(
                st.one_of(
                    st.sampled_from(["nan", "inf", "-inf", "0", "-1", "1e300", "-0"]),
                    st.floats(-1e3, 1e3, allow_nan=False).map(repr),
                )
            )
            text = text[:a] + new + text[b:]
            done.append(f"number {text[a:b]!r} at {a} -> {new!r}")
    return text.encode("utf-8", "surrogatepass"), "; ".join(done)


@FUZZ_SETTINGS
@given(mutant=text_mutants())
def test_text_mutants_of_arm7(mutant: tuple[bytes, str], worker: Worker, tmp_path_factory) -> None:
    _check(mutant, worker, tmp_path_factory, strict=True)


@FUZZ_SETTINGS
@given(mutant=mutants())
def test_lenient_loads_of_mutants(
    mutant: tuple[bytes, str], worker: Worker, tmp_path_factory
) -> None:
    """``strict=False`` loads more mutants: still the library's error, or a usable arm."""
    _check(mutant, worker, tmp_path_factory, strict=False)


def test_worker_reports_an_engine_abort(worker: Worker, tmp_path: Path) -> None:
    """The guard works: a process killed by the engine is a failure, not a lost pytest run."""
    w = Worker("import os, sys; sys.stdin.readline(); os.abort()")
    result = w.load(tmp_path / "x.xml")
    assert result["status"] == "crashed"
    assert w.proc is None


def test_unmutated_arm7_loads_and_agrees(worker: Worker) -> None:
    result = worker.load(rd.model_path("arm7"))
    assert result["status"] == "loaded" and result["equivalent"] and result["agree"]


@pytest.fixture(scope="module", autouse=True)
def _closing_note() -> object:
    yield
    if STATS:
        print("\nfuzz outcomes: " + ", ".join(f"{k}: {n}" for k, n in sorted(STATS.items())))
