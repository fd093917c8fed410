"""Where ``bench size`` and ``bench aep --refine`` start their solves, before and after a
change: two runs' output files compared (issue 40 item 3).

Reads two ``bench size`` folders (``sizing.json``) and/or two ``bench aep --refine``
folders (``aep.json``), and prints per run the wall time, the solves, how each started
(``warm_from``: a cold start by the stored guess or the homotopy, the reference drive's
optimum, a sweep cycle, a neighbour) with their solver wall time, and the AEPs of the
second run relative to the first's.

Usage (run the two versions of the command first, into two folders)::

    .venv/bin/python benchmarks/start_reuse.py --size BEFORE_SIZE AFTER_SIZE \\
        --aep BEFORE_AEP AFTER_AEP
"""

from __future__ import annotations

import argparse
import json
from collections import Counter
from pathlib import Path


def start_of(warm_from: str | None, reference: str = "x1") -> str:
    """The class of a solve's start: ``stored guess``, ``homotopy``, ``reference``,
    ``sweep cycle`` or ``neighbour``."""
    text = warm_from or "?"
    if "m/s" not in text:
        return text
    if text.startswith(f"{reference} "):
        return "reference"
    return "sweep cycle" if text.startswith("sweep ") else "neighbour"


def starts_table(solves: list[dict]) -> str:
    """``homotopy 5 (312 s), neighbour 15 (160 s)``: solves per start class and their
    wall time (a solve loaded from the store, as ``bench size --extend``'s later rounds load
    the earlier ones, counts with the start and time it was solved with)."""
    count, wall = Counter(), Counter()
    for s in solves:
        cls = start_of(s.get("warm_from"))
        count[cls] += 1
        wall[cls] += s.get("wall_time_s") or 0.0
    return ", ".join(f"{c} {count[c]} ({wall[c]:.0f} s)" for c in sorted(count))


def size_rows(before: Path, after: Path) -> None:
    """Print the two sizings: wall time, starts, AEP per candidate."""
    docs = [json.loads((p / "sizing.json").read_text()) for p in (before, after)]
    for name, d in zip(("before", "after"), docs, strict=True):
        print(f"size {name}: {d['wall_time_s']:.1f} s, {d['n_solved']} solved; starts: "
              f"{starts_table(d['solves'])}")
    aep = [{c["candidate"]: c["aep_elec_mwh"] for c in d["candidates"]} for d in docs]
    print("| candidate | AEP before [MWh/yr] | AEP after | after / before - 1 |")
    print("|---|---:|---:|---:|")
    for c, a in aep[0].items():
        b = aep[1].get(c)
        rel = "" if a is None or b is None else f"{(b / a - 1) * 100:+.4f} %"
        print(f"| {c} | {a} | {b} | {rel} |")


def aep_rows(before: Path, after: Path) -> None:
    """Print the two refinements: wall time, starts, added speeds and AEP per kind."""
    docs = [json.loads((p / "aep.json").read_text())["refine"] for p in (before, after)]
    for name, d in zip(("before", "after"), docs, strict=True):
        solves = [s for k in d["kinds"].values() for s in k["solves"]]
        print(f"aep --refine {name}: {d['wall_time_s']:.1f} s, {d['n_solved']} solved; "
              f"starts: {starts_table(solves)}")
    print("| kind | added before | added after | AEP el before | after | rel |")
    print("|---|---|---|---:|---:|---:|")
    for kind, k0 in docs[0]["kinds"].items():
        k1 = docs[1]["kinds"][kind]
        added = [", ".join(f"{s['wind_speed_m_s']:g}" for s in k["solves"]
                           if s["role"] == "added") for k in (k0, k1)]
        rel = (k1["aep_elec_mwh"] / k0["aep_elec_mwh"] - 1) * 100
        print(f"| {kind} | {added[0]} | {added[1]} | {k0['aep_elec_mwh']:.6f} | "
              f"{k1['aep_elec_mwh']:.6f} | {rel:+.4f} % |")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--size", nargs=2, type=Path, metavar=("BEFORE", "AFTER"))
    ap.add_argument("--aep", nargs=2, type=Path, metavar=("BEFORE", "AFTER"))
    args = ap.parse_args(argv)
    if args.size:
        size_rows(*args.size)
    if args.aep:
        aep_rows(*args.aep)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
