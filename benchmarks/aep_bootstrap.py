"""Bootstrap check of the envelope-theorem band.

The analytic one-sigma of the optimal cycle-average electrical power is
``sqrt(g^T Sigma g)`` (``energy.bands``): ``g`` the cycle-time averages of the
model's basis terms on the optimal cycle, ``Sigma`` the fit's coefficient
covariance. Brute force: resample the store's operating points with
replacement (within each quadrant, the fit's weighting unit), refit the same
terms with the same weighting, re-optimize (elec-lim) at two wind speeds, and
take the standard deviation of the optimal power over the resamples. The two
must agree within 20 %.

Usage (after ``bench ingest`` and ``bench fit``)::

    .venv/bin/python benchmarks/aep_bootstrap.py --store demo_out/bench_store \
        --model demo_out/fit/power_model.json --resamples 100 --workers 2

Prints, per wind speed: the nominal optimum, the analytic sigma, the bootstrap
sigma with its standard error, and the ratio.
"""

from __future__ import annotations

import argparse
import dataclasses
import multiprocessing
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from energy.bands import basis_averages
from fitting.model_file import load_power_model
from fitting.points import load_points
from fitting.power_fit import fit_power_model, quadrant_weights
from optimize.resolve import resolve


def _setup(model, winds, intervals):
    """Build the OCP for ``model`` and solve elec-lim at each wind (from a cold start)."""
    from optimize.model.kite_model import kite_dae
    from optimize.problem.ocp import build_ocp
    from optimize.problem.options import Discretization, OcpOptions
    from optimize.problem.scenario import Scenario
    from optimize.solve.solve import solve
    from optimize.solve.starts.cold import start

    dae, options = kite_dae(), OcpOptions(Discretization(n_intervals=intervals))
    ocp = build_ocp(dae, model, options,
        system=resolve(None, model).system)
    first = start(ocp, Scenario(7.0, "electrical", True))
    base = {}
    warm = first.warm
    for v in winds:
        r = solve(ocp, Scenario(v, "electrical", True), warm)
        base[v] = r
        warm = r.warm
    return dae, options, base


def _worker(args):
    """Refit on each resample of this worker's share and re-optimize at every wind."""
    model_path, store, winds, intervals, seeds = args
    from optimize.problem.ocp import build_ocp
    from optimize.problem.scenario import Scenario
    from optimize.solve.solve import solve

    model = load_power_model(model_path)
    frame = load_points(store).frame
    dae, options, base = _setup(model, winds, intervals)
    rows = []
    for seed in seeds:
        rng = np.random.default_rng(seed)
        idx = np.concatenate([rng.choice(np.flatnonzero(frame["quadrant"] == q),
                                         size=int((frame["quadrant"] == q).sum()))
                              for q in ("motor", "generator")])
        f = frame.iloc[idx]
        fit = fit_power_model(f["speed_rpm"].to_numpy(), f["torque_nm"].to_numpy(),
                              f["p_elec_w"].to_numpy(), model.terms,
                              weights=quadrant_weights(f["quadrant"].to_numpy()),
                              nominal_power_w=model.nominal_power_w)
        m = dataclasses.replace(model, coefficients_rpm=tuple(fit.coefficients_rpm),
                                covariance_rpm=None)
        ocp = build_ocp(dae, m, options,
        system=resolve(None, m).system)
        row = {"seed": seed}
        for v in winds:
            r = solve(ocp, Scenario(v, "electrical", True), base[v].warm)
            row[v] = r.avg_p_elec_w if r.success else np.nan
            row[f"status_{v}"] = r.status
        rows.append(row)
    analytic = {v: (base[v].avg_p_elec_w, basis_averages(base[v].trajectory, model))
                for v in winds}
    return rows, analytic


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--store", type=Path, required=True)
    ap.add_argument("--model", type=Path, required=True, help="power_model.json of bench fit")
    ap.add_argument("--winds", default="5.5,8.5", help="two wind speeds at 100 m [m/s]")
    ap.add_argument("--resamples", type=int, default=100)
    ap.add_argument("--intervals", type=int, default=20,
                    help="collocation intervals (coarse keeps 2 x resamples solves affordable)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seed", type=int, default=2015)
    args = ap.parse_args(argv)
    winds = tuple(float(w) for w in args.winds.split(","))
    model = load_power_model(args.model)
    if model.covariance_rpm is None:
        raise SystemExit(f"{args.model} has no covariance")
    seeds = [args.seed + i for i in range(args.resamples)]
    shares = [seeds[i :: args.workers] for i in range(args.workers)]
    t0 = time.perf_counter()
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(args.workers, mp_context=ctx) as pool:
        results = list(pool.map(_worker, [(args.model, args.store, winds, args.intervals, s)
                                          for s in shares]))
    wall = time.perf_counter() - t0
    rows = [r for rs, _ in results for r in rs]
    analytic = results[0][1]
    print(f"model {args.model} ({model.name}), {len(rows)} resamples, N = {args.intervals}, "
          f"{args.workers} workers, {wall:.0f} s")
    ok = True
    for v in winds:
        p0, g = analytic[v]
        s_an = model.sigma_of_basis(g)
        vals = np.array([r[v] for r in rows], dtype=float)
        failed = int(np.sum(~np.isfinite(vals)))
        vals = vals[np.isfinite(vals)]
        s_bs = float(np.std(vals, ddof=1))
        se = s_bs / np.sqrt(2 * (len(vals) - 1))  # standard error of a normal sample's std
        ratio = s_an / s_bs
        ok &= abs(ratio - 1) <= 0.2
        print(f"  {v:4.1f} m/s: P* = {p0:8.2f} W  analytic sigma {s_an:6.3f} W  bootstrap "
              f"sigma {s_bs:6.3f} +- {se:5.3f} W (mean {np.mean(vals):8.2f} W, {failed} failed)"
              f"  ratio {ratio:.3f}")
    print("agree within 20 %" if ok else "DISAGREE by more than 20 %")
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(main())
