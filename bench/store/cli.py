"""``bench store check [--store DIR]``: verify a store without changing it.

Every file the manifest lists must exist with the size and SHA-256 the manifest
records. Prints one line per problem (also generation and staging folders an
interrupted ingest or a hand edit left) and exits 0 for a healthy store, 1 for
a damaged one (``bench ingest`` of the damaged sessions' folders repairs it),
2 when the path is no store.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from bench.store.damage import check_store
from bench.store.manifest import read_manifest
from kernel.errors import InputError

#: exit code of ``bench store check`` when a listed file cannot be trusted
EXIT_DAMAGED = 1


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the ``store`` actions."""
    parser.add_argument("action", choices=["check"],
                        help="check: verify every listed file (exit 1 on damage), change nothing")
    parser.add_argument("--store", type=Path, default=Path("bench_store"),
                        help="store directory (default: ./bench_store)")


def run(args: argparse.Namespace) -> int:
    """Check the store and print what was found."""
    store = args.store
    if not (store / "manifest.json").is_file():
        raise InputError(store / "manifest.json", "no store manifest",
                         expected="a store written by bench ingest")
    manifest = read_manifest(store)
    damage = check_store(store, manifest)
    n_files = sum(len(e.get("store_files") or {}) for e in manifest["sessions"].values()
                  if isinstance(e, dict))
    print(f"store {store}: generation {manifest.get('generation')}, "
          f"{len(manifest['sessions'])} sessions, {n_files} files listed")
    for line in damage.lines():
        print(f"  {line}")
    if damage.damaged:
        print(f"DAMAGED: {len(damage.sessions)} sessions cannot be trusted"
              + (" (the manifest's generation is missing)" if damage.generation else "")
              + "; bench ingest of their folders re-ingests them, nothing else is removed")
        return EXIT_DAMAGED
    print("ok: every listed file is present with its recorded size and SHA-256")
    return 0
