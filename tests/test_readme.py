"""The README, every page of the guide (docs/guide/*.md) and the docs site's pages run: each
document's ```python blocks, in order, in one namespace of its own (as one script would:
``__name__`` is ``"__main__"``), from the repository root; every ``redundancy ...`` command of its ```sh /
```console blocks through the CLI's ``main()``.

A failure names the document and the block's line in it (the test ids are
``<document>:python-L<line>`` and ``<document>:sh-L<line>``), and a traceback inside a block
shows the document's own line numbers.

Shell blocks share one environment: ``NAME=$(...)`` lines are run by bash (with this Python's
``bin`` first on PATH) and ``$NAME`` is replaced in later commands. In ```console blocks only
``$ `` lines are commands. ``redundancy lab`` serves until stopped, so its command lines are
parsed (every argument checked) but not served; lines that are not ``redundancy`` commands
(``make``, ``sed``, scripts) are not run here.
"""

from __future__ import annotations

import os
import re
import shlex
import socket
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
GUIDE = ROOT / "docs" / "guide"
DOCS = ROOT / "docs"
DOCUMENTS = [README, *sorted(GUIDE.glob("*.md")), DOCS / "index.md", *sorted(DOCS.glob("api/*.md"))]
SHELLS = ("sh", "console", "bash", "shell")
REPO_URL = "https://github.com/redundancy-robotics/redundancy/blob/main/"


@dataclass(frozen=True)
class Block:
    lang: str
    line: int  # the document's line of the block's first code line
    code: str
    doc: str = "README.md"  # the document, relative to the repository root

    @property
    def id(self) -> str:
        kind = "python" if self.lang == "python" else "sh"
        return f"{self.doc}:{kind}-L{self.line}"


def blocks(text: str, doc: str = "README.md") -> list[Block]:
    """The fenced code blocks of a Markdown text, with the line each starts on."""
    out, lang, start, body = [], None, 0, []
    for n, line in enumerate(text.splitlines(), start=1):
        fence = re.match(r"^```(\S*)\s*$", line)
        if lang is None and fence:
            lang, start, body = fence.group(1) or "text", n + 1, []
        elif lang is not None and line.startswith("```"):
            out.append(Block(lang, start, "\n".join(body), doc))
            lang = None
        elif lang is not None:
            body.append(line)
    assert lang is None, f"{doc}: the block opened at line {start - 1} is never closed"
    return out


def _relative(path: Path) -> str:
    return path.relative_to(ROOT).as_posix()


BLOCKS = [b for path in DOCUMENTS for b in blocks(path.read_text(), _relative(path))]
PYTHON = [b for b in BLOCKS if b.lang == "python"]
SHELL = [b for b in BLOCKS if b.lang in SHELLS]


@pytest.fixture(scope="module")
def namespaces() -> dict[str, dict[str, Any]]:
    """One namespace per document, shared by its blocks in order."""
    return {}


@pytest.fixture(scope="module")
def shell_envs() -> dict[str, dict[str, str]]:
    return {}


@pytest.mark.parametrize("block", PYTHON, ids=[b.id for b in PYTHON])
def test_python_block(
    block: Block, namespaces: dict[str, dict[str, Any]], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(ROOT)
    namespace = namespaces.setdefault(block.doc, {"__name__": "__main__"})
    # Padded so that the code's line numbers are the document's: a traceback points at the line.
    code = compile("\n" * (block.line - 1) + block.code, str(ROOT / block.doc), "exec")
    try:
        exec(code, namespace)
    except Exception as err:
        raise AssertionError(
            f"{block.doc} line {block.line}: the python block fails: {type(err).__name__}: {err}"
        ) from err


def _page(doc: str) -> list[str]:
    """The python blocks of one document, in order."""
    return [b.code for b in PYTHON if b.doc == doc]


#: Pages whose examples start processes: a script's workers import it again, which the blocks
#: run in this process (``__name__ == "__main__"``, as in a script) cannot show.
STARTS_PROCESSES = ["docs/guide/batch-and-clusters.md"]


@pytest.fixture
def dask_port_taken() -> Iterator[None]:
    """Dask's default status port held, as by a cluster already running (if it is free)."""
    with socket.socket() as s:
        try:
            s.bind(("127.0.0.1", 8787))
            s.listen()
        except OSError:
            pass  # already taken
        yield


@pytest.mark.parametrize("doc", STARTS_PROCESSES)
def test_a_page_runs_as_a_script(doc: str, tmp_path: Path, dask_port_taken: None) -> None:
    """``python page.py``: a Dask cluster's workers import the script again, so the page's
    cluster must start under ``if __name__ == "__main__":``."""
    script = tmp_path / "page.py"
    script.write_text("\n\n".join(_page(doc)))
    run = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, cwd=ROOT, timeout=600
    )
    assert run.returncode == 0, f"{doc} as a script:\n{run.stderr[-3000:]}"
    assert "already in use" not in run.stderr


@pytest.mark.parametrize("doc", STARTS_PROCESSES)
def test_a_page_runs_in_a_notebook(doc: str, dask_port_taken: None) -> None:
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(c) for c in _page(doc)])
    client = nbclient.NotebookClient(
        nb, timeout=600, kernel_name="python3", resources={"metadata": {"path": str(ROOT)}}
    )
    client.execute()  # raises CellExecutionError naming the cell on any error
    stderr = [o.get("text", "") for c in nb.cells for o in c.outputs if o.get("name") == "stderr"]
    assert not any("already in use" in s for s in stderr), stderr


def _commands(block: Block) -> list[tuple[int, str]]:
    """(document line, command) of each command line, comments and prompts stripped."""
    out = []
    for k, raw in enumerate(block.code.splitlines()):
        line = raw.strip()
        if block.lang == "console":
            if not line.startswith("$ "):
                continue
            line = line[2:]
        if not line or line.startswith("#"):
            continue
        out.append((block.line + k, line))
    return out


def _expand(text: str, env: dict[str, str]) -> str:
    return re.sub(r"\$(\w+)|\$\{(\w+)\}", lambda m: env[m.group(1) or m.group(2)], text)


@pytest.mark.parametrize("block", SHELL, ids=[b.id for b in SHELL])
def test_shell_block(
    block: Block,
    shell_envs: dict[str, dict[str, str]],
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    from redundancy import cli

    monkeypatch.chdir(ROOT)
    shell_env = shell_envs.setdefault(block.doc, {})
    path = f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"
    for line_no, line in _commands(block):
        where = f"{block.doc} line {line_no}: {line}"
        assign = re.match(r"^(\w+)=(\$\(.*\))$", line)
        if assign:
            run = subprocess.run(
                ["bash", "-c", f'{line}\nprintf %s "${assign.group(1)}"'],
                capture_output=True,
                text=True,
                env={**os.environ, "PATH": path},
                cwd=ROOT,
                timeout=120,
            )
            assert run.returncode == 0 and run.stdout, f"{where}\n{run.stderr}"
            shell_env[assign.group(1)] = run.stdout
            continue
        if not line.startswith("redundancy "):
            continue
        argv = shlex.split(_expand(line, shell_env), comments=True)[1:]
        if argv[:1] == ["lab"]:
            cli._parser().parse_args(argv)  # serves until stopped: the arguments only
            continue
        status = cli.main(argv)
        err = capsys.readouterr().err
        assert status in (0, 1), f"{where}\nexit status {status}: {err[-2000:]}"


def _anchor(heading: str) -> str:
    """GitHub's (and mkdocs'): lower case, punctuation dropped, - for a space."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def _anchors(path: Path) -> set[str]:
    text = re.sub(r"^```.*?^```", "", path.read_text(), flags=re.M | re.S)  # no code comments
    return {_anchor(h) for h in re.findall(r"^#{1,4} (.+)$", text, flags=re.M)}


@pytest.mark.parametrize("path", DOCUMENTS, ids=[_relative(p) for p in DOCUMENTS])
def test_no_placeholders_and_every_link_resolves(path: Path) -> None:
    text = path.read_text()
    for placeholder in ("my_arm.xml", "robot.urdf", "robot.srdf", "vendor_arm.xml"):
        assert not re.search(rf"(?<![\w.]){re.escape(placeholder)}", text), placeholder
    broken = []
    for target in re.findall(r"\]\(([^)\s]+)\)", text):
        if target.startswith(REPO_URL):  # a file of this repository, as GitHub shows it
            file, anchor = ROOT / target.removeprefix(REPO_URL), ""
        elif re.match(r"^\w+:", target):
            continue  # another site
        else:
            name, _, anchor = target.partition("#")
            file = (path.parent / name).resolve() if name else path
        if not file.exists() or (anchor and anchor not in _anchors(file)):
            broken.append(target)
    assert broken == [], f"{_relative(path)}: links to nothing"


def test_the_readme_is_short_and_links_every_guide_page() -> None:
    text = README.read_text()
    assert len(text.splitlines()) <= 250
    assert "make audit" in text and "make test" in text
    linked = set(re.findall(r"\]\(docs/guide/([\w-]+\.md)\)", text))
    pages = {p.name for p in GUIDE.glob("*.md")} - {"index.md"}
    assert pages - linked == set()
    nav = (ROOT / "mkdocs.yml").read_text()
    assert [p for p in sorted(pages | {"index.md"}) if f"guide/{p}" not in nav] == []


def test_blocks_parser_gives_readme_line_numbers() -> None:
    found = blocks("intro\n```python\nx = 1\ny = 2\n```\n\n```sh\nredundancy audit\n```\n", "a.md")
    assert found == [
        Block("python", 3, "x = 1\ny = 2", "a.md"),
        Block("sh", 8, "redundancy audit", "a.md"),
    ]
    assert found[0].id == "a.md:python-L3"
    assert _commands(Block("console", 10, "$ redundancy audit\noutput\n$ make test")) == [
        (10, "redundancy audit"),
        (12, "make test"),
    ]
