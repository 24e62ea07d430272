"""Every code example in README.md and docs/ runs, and the documentation site builds.

How each fenced block counts (docs/index.md tells readers the same):

- ``python``: executed; the blocks of one page share a namespace and run in document order, in a
  scratch directory, so a page's later blocks use the files its earlier ones wrote;
- ``sh``: each line runs with bash in the same scratch directory, with the venv's ``sail`` first on
  PATH and ``c`` linking to the repository's ``c/``; a ``make TARGET`` line must instead pass
  ``make -n TARGET`` in the repository (the targets themselves are what CI runs);
- ``c``: the block's first line names its file (``/* example.c */``); it is written there, and a
  later ``sh`` line of the page must compile it;
- ``toml``: loaded as a robot file;
- ``text``: drawings and printed output, not run.

A fence with no language, or another one, fails: an example the tests do not know how to run.
"""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = sorted([ROOT / "README.md", *(ROOT / "docs").rglob("*.md")])
FENCE = re.compile(r"^(?P<indent> *)```(?P<lang>[\w+-]*)[^\n]*\n(?P<body>.*?)^(?P=indent)```[ \t]*$", re.M | re.S)
RUNNABLE = {"python", "sh", "c", "toml", "text"}
#: A shell line may run this long [s]: the slowest, `sail reproduce` or the motion pipeline, take ~10 s.
LINE_TIMEOUT_S = 300


def fences(page: Path) -> list[tuple[str, str, int]]:
    """``(language, body, line number)`` of each fenced block, in order, the body de-indented."""
    text = page.read_text(encoding="utf-8")
    blocks = []
    for match in FENCE.finditer(text):
        indent = len(match["indent"])
        body = "".join(line[indent:] for line in match["body"].splitlines(keepends=True))
        blocks.append((match["lang"], body, text.count("\n", 0, match.start()) + 1))
    return blocks


def _shell_lines(body: str) -> list[str]:
    """Commands of an ``sh`` block: blank lines and whole-line comments dropped, continuations joined."""
    joined = re.sub(r"\\\n\s*", " ", body)
    return [line for line in joined.splitlines() if line.strip() and not line.lstrip().startswith("#")]


def _run_shell(line: str, scratch: Path, where: str) -> None:
    words = shlex.split(line, comments=True)
    if words and words[0] == "make":
        assert len(words) >= 2, f"{where}: `{line}` names no target"
        dry = subprocess.run(["make", "-n", *words[1:]], cwd=ROOT, capture_output=True, text=True)
        assert dry.returncode == 0, f"{where}: `make -n {' '.join(words[1:])}` failed:\n{dry.stderr}"
        return
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}",
           "NO_COLOR": "1", "COLUMNS": "100"}  # fmt: skip
    result = subprocess.run(["bash", "-euo", "pipefail", "-c", line], cwd=scratch, env=env, capture_output=True,
                            text=True, timeout=LINE_TIMEOUT_S)  # fmt: skip
    assert result.returncode == 0, f"{where}: `{line}` exited {result.returncode}:\n{result.stdout}\n{result.stderr}"


def _pages_with_examples() -> list[Path]:
    return [page for page in PAGES if fences(page)]


@pytest.mark.parametrize("page", _pages_with_examples(), ids=lambda p: str(p.relative_to(ROOT)))
def test_every_example_runs(page: Path, tmp_path: Path) -> None:
    from sailforce.io.robotfile import load_robot_file

    scratch = tmp_path / "scratch"
    scratch.mkdir()
    (scratch / "c").symlink_to(ROOT / "c")
    namespace: dict[str, object] = {"__name__": "__docs__"}
    c_files: list[str] = []
    ran = 0
    cwd = Path.cwd()
    os.chdir(scratch)
    try:
        for lang, body, line in fences(page):
            where = f"{page.relative_to(ROOT)}:{line}"
            assert lang in RUNNABLE, f"{where}: a ```{lang or '(no language)'} block; label it {sorted(RUNNABLE)}"
            if lang == "python":
                exec(compile(body, where, "exec"), namespace)
            elif lang == "sh":
                for command in _shell_lines(body):
                    _run_shell(command, scratch, where)
                    c_files = [name for name in c_files if name not in command]
            elif lang == "c":
                name = re.match(r"/\* (\w+\.c) \*/", body)
                assert name, f"{where}: a C example starts with a /* NAME.c */ line naming its file"
                (scratch / name[1]).write_text(body)
                c_files.append(name[1])
            elif lang == "toml":
                (scratch / "example.toml").write_text(body)
                load_robot_file(scratch / "example.toml")
            ran += lang != "text"
    finally:
        os.chdir(cwd)
    assert not c_files, f"{page.relative_to(ROOT)}: C examples no sh line compiles: {c_files}"
    assert ran or all(lang == "text" for lang, _, _ in fences(page))


def test_every_page_is_in_the_site() -> None:
    """Each page under docs/ is in mkdocs.yml's navigation, so none is written and never shown."""
    nav = (ROOT / "mkdocs.yml").read_text()
    for page in (ROOT / "docs").rglob("*.md"):
        assert str(page.relative_to(ROOT / "docs")) in nav, page


@pytest.mark.skipif(shutil.which("mkdocs", path=str(Path(sys.executable).parent)) is None,
                    reason="mkdocs is in the dev extras")  # fmt: skip
def test_site_builds_strictly(tmp_path: Path) -> None:
    """``mkdocs build --strict``: every link resolves, every API page renders from the docstrings."""
    mkdocs = Path(sys.executable).parent / "mkdocs"
    result = subprocess.run([str(mkdocs), "build", "--strict", "--site-dir", str(tmp_path / "site")], cwd=ROOT,
                            capture_output=True, text=True, env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})  # fmt: skip
    assert result.returncode == 0, result.stderr
    cli = (tmp_path / "site" / "reference" / "cli" / "index.html").read_text()
    for command in ("sail calibrate", "sail estimate", "sail export-c", "sail reproduce", "sail simulate-motion"):
        assert command in cli, command
    api = (tmp_path / "site" / "reference" / "api" / "calibration" / "index.html").read_text()
    assert "fit_calibration" in api and "Calibration" in api
