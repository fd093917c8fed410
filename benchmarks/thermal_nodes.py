"""How many thermal nodes bench fit chooses, and how well it recovers them.

Usage::

    PYTHONPATH=. .venv/bin/python benchmarks/thermal_nodes.py [--seeds 10] [--store STORE]

1. Synthetic logs with a known network (:mod:`bench.synth.thermal_ladder`: the node
   equations integrated exactly, 0.2 K sensor noise, heat steps of 1-5 min up to
   1.5 kW): a one-node truth (36 kJ/K, 0.06 K/W) and a two-node truth (winding 2 kJ/K,
   0.02 K/W to a 20 kJ/K housing, 0.04 K/W to ambient), three sessions of 2 h each and
   one session of 4 h (cross-validated in thirds), per seed: the chosen number of nodes,
   the held-out RMS of each candidate, and the fitted ladder's largest relative error.
2. With ``--store``: the store's own fit (``fitting.thermal.fit_thermal``), e.g. the
   shipped campaign (``bench ingest raw_measurements --store STORE``), whose truth
   (``truth.json`` ``thermal``) is one node.

Writes ``benchmarks/out/thermal_nodes.json``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from bench.synth.thermal_ladder import heat_steps, winding_bin_means
from fitting.thermal_network import fit_network, ladder_of
from fitting.thermal_selection import select_nodes

OUT = Path(__file__).resolve().parent / "out"
BIN_S = 5.0
TRUTHS = {"one node": ((36000.0, 0.06),),
          "two nodes": ((2000.0, 0.02), (20000.0, 0.04))}


def campaign(ladder, seed: int, sessions: int, hours: float) -> dict[str, dict]:
    """Logged sessions of a known ladder (ambient 20, 22.5, ... degC)."""
    rng = np.random.default_rng(seed)
    out = {}
    for i in range(sessions):
        q = heat_steps(rng, int(hours * 3600 / BIN_S))
        theta = 20.0 + 2.5 * i + winding_bin_means(ladder, q, BIN_S)
        out[f"s{i}"] = {"heat_w": q, "theta_c": theta + rng.normal(0, 0.2, q.size),
                        "bin_s": BIN_S}
    return out


def one_case(ladder, seed: int, sessions: int, hours: float) -> dict:
    series = campaign(ladder, seed, sessions, hours)
    t0 = time.perf_counter()
    selection = select_nodes(series)
    n = selection["chosen_nodes"]
    fit = fit_network(series, n)
    row = {"seed": seed, "chosen": n, "unit": selection["unit"],
           "cv_rms_k": {c["nodes"]: round(c["cv_rms_k"], 3) for c in selection["candidates"]},
           "seconds": round(time.perf_counter() - t0, 2)}
    if n == len(ladder):
        row["max_rel_error"] = float(np.max(np.abs(ladder_of(fit["modes"]) / np.array(ladder)
                                                   - 1)))
    return row


def store_case(store: Path) -> dict:
    from bench.store.read import read_points, read_samples
    from fitting.thermal import fit_thermal

    thermal, note = fit_thermal(read_points(store), lambda s: read_samples(store, s))
    return {"note": note, "nodes": None if thermal is None else thermal.nodes,
            "selection": None if thermal is None else thermal.selection}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--store", type=Path)
    args = ap.parse_args()
    report: dict = {"cases": {}}
    for truth, ladder in TRUTHS.items():
        for sessions, hours in ((3, 2.0), (1, 4.0)):
            key = f"{truth}, {sessions} x {hours:g} h"
            rows = [one_case(ladder, seed, sessions, hours) for seed in range(args.seeds)]
            report["cases"][key] = rows
            right = sum(r["chosen"] == len(ladder) for r in rows)
            errors = [r["max_rel_error"] for r in rows if "max_rel_error" in r]
            print(f"{key}: {right}/{len(rows)} chose {len(ladder)} node(s); largest ladder "
                  f"error {max(errors):.1%} (median {np.median(errors):.1%})" if errors else
                  f"{key}: {right}/{len(rows)} right", flush=True)
    if args.store is not None:
        report["store"] = store_case(args.store)
        print(json.dumps(report["store"], indent=1))
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "thermal_nodes.json").write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
