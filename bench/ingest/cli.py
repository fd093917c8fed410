"""``bench ingest PATH... [--store DIR] [--mapping FILE]``: bench logs into the Parquet store."""

from __future__ import annotations

import argparse
from pathlib import Path

from bench.ingest.pipeline import to_stderr
from bench.ingest.summary import format_summary


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the ``ingest`` options."""
    parser.add_argument("paths", nargs="+", type=Path, metavar="PATH",
                        help="campaign or session folders (sessions hold a session.toml)")
    parser.add_argument("--store", type=Path, default=Path("bench_store"),
                        help="store directory (default: ./bench_store)")
    parser.add_argument("--mapping", type=Path, default=None,
                        help="column mapping (TOML or JSON) for sessions without their own")
    parser.add_argument("--workers", type=int, default=2,
                        help="sessions processed at the same time (default 2)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    parser.add_argument("--strict", action="store_true",
                        help="a session that gives no operating point is an error (exit 2)")
    parser.add_argument("--no-wait", action="store_true",
                        help="stop when another ingest is writing the store (default: wait)")
    parser.add_argument("--no-replace", action="store_true",
                        help="refuse to replace stored sessions of the same id ingested from "
                             "another folder (default: replace them and say so)")


def run(args: argparse.Namespace) -> int:
    """Ingest (:func:`bench.ingest.pipeline.ingest`), then print the summary table;
    InputError propagates to the dispatcher."""
    from bench.ingest.pipeline import ingest

    result = ingest(args.paths, args.store, mapping_path=args.mapping,
                    progress=not args.no_progress, workers=args.workers, strict=args.strict,
                    wait=not args.no_wait, replace=not args.no_replace, notify=to_stderr,
                    command_line=args.command_line)
    print(format_summary(result.ingested, result.unchanged, result.manifest,
                         result.repaired))
    print(f"store: {result.store_dir}")
    return 0
