"""The README runs: every ```python block, in order, in one namespace, from the repository
root; every ``redundancy ...`` command of its ```sh / ```console blocks through the CLI's
``main()``.

A failure names the block by its line in README.md (the test ids are ``python-L<line>`` and
``sh-L<line>``), and a traceback inside a block shows README.md's own line numbers.

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
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
SHELLS = ("sh", "console", "bash", "shell")


@dataclass(frozen=True)
class Block:
    lang: str
    line: int  # README line of the block's first code line
    code: str

    @property
    def id(self) -> str:
        kind = "python" if self.lang == "python" else "sh"
        return f"{kind}-L{self.line}"


def blocks(text: str) -> list[Block]:
    """The fenced code blocks of a Markdown text, with the line each starts on."""
    out, lang, start, body = [], None, 0, []
    for n, line in enumerate(text.splitlines(), start=1):
        fence = re.match(r"^```(\S*)\s*$", line)
        if lang is None and fence:
            lang, start, body = fence.group(1) or "text", n + 1, []
        elif lang is not None and line.startswith("```"):
            out.append(Block(lang, start, "\n".join(body)))
            lang = None
        elif lang is not None:
            body.append(line)
    assert lang is None, f"README.md: the block opened at line {start - 1} is never closed"
    return out


BLOCKS = blocks(README.read_text())
PYTHON = [b for b in BLOCKS if b.lang == "python"]
SHELL = [b for b in BLOCKS if b.lang in SHELLS]


@pytest.fixture(scope="module")
def namespace() -> dict[str, Any]:
    return {"__name__": "__readme__"}


@pytest.fixture(scope="module")
def shell_env() -> dict[str, str]:
    return {}


@pytest.mark.parametrize("block", PYTHON, ids=[b.id for b in PYTHON])
def test_python_block(
    block: Block, namespace: dict[str, Any], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(ROOT)
    # Padded so that the code's line numbers are README.md's: a traceback points at the line.
    code = compile("\n" * (block.line - 1) + block.code, str(README), "exec")
    try:
        exec(code, namespace)
    except Exception as err:
        raise AssertionError(
            f"README.md line {block.line}: the python block fails: {type(err).__name__}: {err}"
        ) from err


def _commands(block: Block) -> list[tuple[int, str]]:
    """(README line, command) of each command line, comments and prompts stripped."""
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
    shell_env: dict[str, str],
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    from redundancy import cli

    monkeypatch.chdir(ROOT)
    path = f"{Path(sys.executable).parent}{os.pathsep}{os.environ.get('PATH', '')}"
    for line_no, line in _commands(block):
        where = f"README.md line {line_no}: {line}"
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


def test_no_placeholders_and_the_contents_resolve() -> None:
    text = README.read_text()
    for placeholder in ("my_arm.xml", "robot.urdf", "robot.srdf", "vendor_arm.xml"):
        assert not re.search(rf"(?<![\w.]){re.escape(placeholder)}", text), placeholder

    def anchor(heading: str) -> str:  # GitHub's: lower case, punctuation dropped, - for space
        return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")

    headings = {anchor(h) for h in re.findall(r"^#{2,3} (.+)$", text, flags=re.M)}
    contents = text.split("## Contents", 1)[1].split("\n## ", 1)[0]
    links = re.findall(r"\]\(#([^)]+)\)", contents)
    assert len(links) >= 15
    assert [a for a in links if a not in headings] == []
    top = [anchor(h) for h in re.findall(r"^## (.+)$", text, flags=re.M)]
    assert [a for a in top if a not in links and a != "contents"] == []


def test_blocks_parser_gives_readme_line_numbers() -> None:
    found = blocks("intro\n```python\nx = 1\ny = 2\n```\n\n```sh\nredundancy audit\n```\n")
    assert found == [Block("python", 3, "x = 1\ny = 2"), Block("sh", 8, "redundancy audit")]
    assert _commands(Block("console", 10, "$ redundancy audit\noutput\n$ make test")) == [
        (10, "redundancy audit"),
        (12, "make test"),
    ]
