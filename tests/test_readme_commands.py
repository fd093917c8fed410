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
