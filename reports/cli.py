"""``bench report``: render the self-contained HTML report from the stages' output files."""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from kernel.files import check_output_file
from kernel.output_folder import output_file
from reports.render import build_report


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the ``bench report`` options."""
    parser.add_argument("--store", type=Path, default=Path("bench_store"),
                        help="store folder written by `bench ingest` (default: ./bench_store)")
    parser.add_argument("--fit", type=Path, default=Path("fit_out"),
                        help="output folder of `bench fit` (default: ./fit_out)")
    parser.add_argument("--optimize", type=Path, default=Path("optimize_out"),
                        help="output folder of `bench optimize` (default: ./optimize_out)")
    parser.add_argument("--aep", type=Path, default=Path("aep_out"),
                        help="output folder of `bench aep` (default: ./aep_out)")
    parser.add_argument("--size", type=Path, default=Path("size_out"),
                        help="output folder of `bench size` (default: ./size_out)")
    parser.add_argument("--verify", type=Path, default=Path("verify_out"),
                        help="output folder of `bench cycle verify` (default: ./verify_out; "
                        "none: the section says the stage was not run)")
    parser.add_argument("--out", type=Path, default=Path("report.html"),
                        help="the HTML file to write (default: ./report.html)")


#: in the head of every report (reports/templates/report.html), and the heading of those
#: written before it: how an earlier report is known (``--out`` replaces nothing else)
REPORT_MARKERS = (b'<meta name="generator" content="drivebench report">',
                  b"from bench logs to electrically optimal pumping cycles</h1>")


def is_report(head: bytes) -> bool:
    """Whether a file starting with ``head`` is a report ``bench report`` wrote."""
    return head.lstrip().startswith(b"<!DOCTYPE html>") and any(m in head for m in REPORT_MARKERS)


def run(args: argparse.Namespace) -> int:
    """Build the report; print its path, size and the wall time."""
    t0 = time.perf_counter()
    check_output_file(args.out)
    argv = list(args.command_line)  # as given: an option not passed is not recorded
    with output_file(args.out, "report", is_report):  # one writer per file: a second waits
        out = build_report(args.store, args.fit, args.optimize, args.out, argv, args.aep,
                           args.size, args.verify)
    size_mb = out.stat().st_size / 1e6
    print(f"{out.resolve()}")
    print(f"bench report: {size_mb:.2f} MB written in {time.perf_counter() - t0:.1f} s")
    return 0
