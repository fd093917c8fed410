"""``docs/cli.md``: every option of every ``bench`` stage in one table per stage, made from
the stages' own argparse parsers, so it cannot go stale.

Write it with ``python -m drivebench.cli_doc > docs/cli.md``; ``tests/test_cli_doc.py``
checks that the file matches :func:`cli_markdown` and that one idea has one name.
"""

from __future__ import annotations

import argparse
import importlib

HEADER = """# The `bench` command line: every option of every stage

Generated from the stages' own option parsers by `python -m drivebench.cli_doc >
docs/cli.md` (tests/test_cli_doc.py fails when this file and the parsers differ). The
same idea has the same name in every stage: `--out` the output folder, `--store`,
`--fit`, `--optimize`, `--aep`, `--size`, `--verify` the folders a stage reads,
`--system` the system file, `--drive-model` the drive's power model, `--wind-grid` the
wind speeds, `--height-m` the height of the site's wind figures, `--workers` and
`--scheduler` where the solves run, `--no-progress` no progress bar (every stage that
shows one). Errors name the subcommand (`bench cycle export: error: ...`) and call an
option an option; bad input exits with code 2.
"""


def stage_parsers() -> list[tuple[str, argparse.ArgumentParser]]:
    """``(subcommand, parser)`` of every stage, a nested action (``cycle export``) as its
    own entry, in the order of ``bench --help``."""
    from drivebench.cli import SUBCOMMANDS

    out = []
    for name, (module, help_text) in SUBCOMMANDS.items():
        parser = argparse.ArgumentParser(prog=f"bench {name}", description=help_text)
        importlib.import_module(module).add_arguments(parser)
        out += _leaves(name, parser)
    return out


def _leaves(name: str,
            parser: argparse.ArgumentParser) -> list[tuple[str, argparse.ArgumentParser]]:
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if not subs:
        return [(name, parser)]
    return [leaf for action, sub in subs[0].choices.items()
            for leaf in _leaves(f"{name} {action}", sub)]


def option_rows(parser: argparse.ArgumentParser) -> list[tuple[str, str, str, str]]:
    """``(option, value, default, help)`` of each option and positional argument of a
    parser (its ``--help`` left out), as its ``--help`` states them."""
    rows = []
    for a in parser._actions:
        if isinstance(a, argparse._HelpAction | argparse._SubParsersAction):
            continue
        names = ", ".join(f"`{s}`" for s in a.option_strings) or f"`{a.metavar or a.dest}`"
        if a.nargs == 0:
            value = ""
        elif a.choices is not None:
            value = " \\| ".join(str(c) for c in a.choices)
        else:
            value = str(a.metavar or a.dest.upper())
            value += " ..." if a.nargs in ("*", "+") else ""
        default = ("" if a.default in (None, False, (), [], argparse.SUPPRESS) or a.required
                   else str(a.default))
        text = (a.help or "") % {**vars(a), "prog": parser.prog}
        rows.append((names, value, default, text.replace("|", "\\|").replace("\n", " ")))
    return rows


def cli_markdown() -> str:
    """The text of ``docs/cli.md``."""
    lines = [HEADER]
    for name, parser in stage_parsers():
        lines += [f"## `bench {name}`", "", (parser.description or "").strip(), "",
                  "| option | value | default | what |", "|---|---|---|---|"]
        lines += [f"| {o} | {v} | {d} | {h} |" for o, v, d, h in option_rows(parser)]
        lines.append("")
    return "\n".join(lines)


if __name__ == "__main__":
    print(cli_markdown(), end="")
