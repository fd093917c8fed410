"""Every `bench` command the README shows parses with that stage's own options (issue 42:
the README's round trip had drifted from the command line)."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from drivebench.cli import build_parser

README = Path(__file__).resolve().parent.parent / "README.md"


def _commands() -> list[str]:
    blocks = re.findall(r"```sh\n(.*?)```", README.read_text(encoding="utf-8"), re.S)
    lines = [re.split(r"\s#", line)[0].strip() for b in blocks for line in b.splitlines()]
    return [line for line in lines if line.startswith("bench ") and line != "bench --version"]


@pytest.mark.parametrize("line", _commands())
def test_readme_command_parses(line):
    argv = shlex.split(line)[1:]
    build_parser(argv).parse_args(argv)  # an unknown option or a missing value exits 2


def test_readme_puts_bench_on_the_path_before_its_first_command():
    # issue 49: the README's commands used `bench` and never said how to get it on the
    # path; run as written in a new shell: "bench: command not found"
    text = README.read_text(encoding="utf-8")
    first = min(text.index(c) for c in _commands())
    activate = text.find("source .venv/bin/activate")
    assert 0 <= activate < first
    root = README.parent
    assert (root / ".venv" / "bin" / "activate").is_file() or not (root / ".venv").exists()


def test_readme_commands_run_in_a_new_shell(tmp_path):
    # what a new shell does with the README's first lines: activate, then `bench --version`
    import subprocess

    root = README.parent
    if not (root / ".venv" / "bin" / "activate").is_file():
        pytest.skip("no .venv here: `make demo` builds it")
    done = subprocess.run(["bash", "-c", "source .venv/bin/activate && cd \"$1\" && "
                           "command -v bench && bench --help", "sh", str(tmp_path)],
                          cwd=root, capture_output=True, text=True, env={"PATH": "/usr/bin:/bin"},
                          timeout=120)
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines()[0] == str(root / ".venv" / "bin" / "bench")
