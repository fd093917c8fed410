"""The ``bench`` command line: a thin dispatcher over the stage packages.

Each subcommand lives in its own module exposing ``add_arguments(parser)`` and
``run(args) -> int`` (``args.command_line``: the command as given, for the stage's
provenance header); this file only wires them up, imports them lazily and
turns :class:`kernel.errors.InputError` into a clear message and exit code 2.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from kernel.errors import InputError
from kernel.files import WRITE_ERRNOS

#: subcommand -> (module, one-line help)
SUBCOMMANDS: dict[str, tuple[str, str]] = {
    "synth": ("bench.synth.cli", "generate a deterministic synthetic bench campaign"),
    "ingest": ("bench.ingest.cli", "ingest bench logs into the Parquet store"),
    "store": ("bench.store.cli", "check a store: every listed file present and as recorded"),
    "fit": ("fitting.cli", "efficiency map, power model fit, model selection, export"),
    "optimize": ("optimize.cli", "periodic pumping-cycle optimization over a wind grid"),
    "aep": ("energy.cli", "annual energy, capacity factor and bands of the power curves at a site"),
    "size": ("energy.size_cli", "drive sizing: electrical AEP against drive rating"),
    "cycle": ("cycle.cli", "fly an optimal cycle on the bench: export it as a drive profile, "
                           "verify the measured energy per cycle"),
    "report": ("reports.cli", "render the self-contained HTML report"),
    "run": ("drivebench.run_cli", "ingest, fit, optimize, aep, size and report in one go"),
}


class _VersionAction(argparse.Action):
    """``--version``: print :func:`kernel.versions.version_text` and exit (the solver
    versions are looked up only when asked for)."""

    def __init__(self, option_strings, dest, **kwargs):
        super().__init__(option_strings, dest, nargs=0, help=kwargs.get("help"))

    def __call__(self, parser, namespace, values, option_string=None):
        from kernel.versions import version_text

        print(version_text())
        parser.exit()


def _load(module_name: str):
    return importlib.import_module(module_name)


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """Build the top-level parser; only the requested subcommand's module is imported."""
    parser = argparse.ArgumentParser(
        prog="bench",
        description="drivebench: from winch-drive bench logs to electrically optimal AWE cycles",
    )
    parser.add_argument("--version", action=_VersionAction,
                        help="print the versions of drivebench, CasADi and IPOPT and exit")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    wanted = next((a for a in (argv or []) if not a.startswith("-")), None)
    for name, (module_name, help_text) in SUBCOMMANDS.items():
        # no abbreviations: `bench size --scale 6` once meant --scales 6
        sp = sub.add_parser(name, help=help_text, description=help_text, allow_abbrev=False)
        if name == wanted:
            _load(module_name).add_arguments(sp)
            sp.set_defaults(_module=module_name)
    return parser


def _subparser(parser: argparse.ArgumentParser,
               args: argparse.Namespace) -> argparse.ArgumentParser:
    """The parser of the subcommand ``args`` names (``bench cycle export``'s, not
    ``bench``'s), so its errors name it."""
    for name in (args.command, getattr(args, "action", None)):
        subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
        if not name or not subs or name not in subs[0].choices:
            break
        parser = subs[0].choices[name]
    return parser


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``bench`` console script."""
    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(argv)
    args, unknown = parser.parse_known_args(argv)
    if unknown:  # named by the subcommand that does not take them (exit 2)
        _subparser(parser, args).error(f"unrecognized arguments: {' '.join(unknown)}")
    args.command_line = ("bench", *argv)  # what the stage records in its provenance header
    # the subcommand its messages name: `bench cycle export`, not `bench cycle`
    name = " ".join(x for x in (args.command, getattr(args, "action", None)) if x)
    try:
        return int(_load(args._module).run(args) or 0)
    except InputError as exc:
        print(f"bench {name}: error: {exc.describe()}", file=sys.stderr)
        return 2
    except OSError as exc:  # a place that cannot be written, found only while writing
        if exc.errno not in WRITE_ERRNOS:
            raise
        where = exc.filename or "<output>"
        print(f"bench {name}: error: {where}: cannot write ({WRITE_ERRNOS[exc.errno]}); "
              "expected a writable output folder", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
