"""Does the efficiency map pass through what was measured? Every campaign, per quadrant.

For the shipped campaign (``raw_measurements/``), the export classes of
``export_fixtures.py``, the rated-drive classes of ``fit_fixtures.py`` and a hobby
dyno table (part-load peak, one outlier row: ``bench.synth.exports``), run
``bench ingest`` and ``bench fit --order 2`` and compare, at every accepted point
(``ok`` under the fit's masking rules), the measured efficiency with the map's.

The map at a point is read from ``efficiency_map.parquet`` as a user would: the
node losses (``loss_w``) interpolated bilinearly from the four surrounding nodes
(the in-domain ones, weights renormalised), the efficiency from the point's exact
omega*T and that loss (paper eqs. 1-2), at most the quadrant's ceiling. A point's
uncertainty is computed here, independently of ``fitting``: the standard error of
its window means (``*_w_std / sqrt(n_samples)``) and 0.2 % of each power reading
(``u_stated``), and the fit's pooled loss repeatability of the quadrant
(``repeatability.loss_repeatability``, a loss at the point's exact P_mech: relative
``repeat_w / |P_elec|``), in quadrature, as a relative uncertainty of the
efficiency. Printed per campaign and quadrant: accepted points, the repeatability,
points above the map (read bilinearly from the grid nodes) by more than
``u_stated`` and by more than their full uncertainty (with the worst excess),
points below it by more than that, the points no in-domain node surrounds, the
measured peak and its uncertainty, the map's peak and ceiling, whether the map
peak is within the measured peak's uncertainty, and the points the fit flags as
outliers (``statistics.outliers``; None where not reported). With ``--before``,
the earlier run's maps read at the same points with both uncertainties.

    .venv/bin/python benchmarks/map_honesty.py [--out DIR] [--campaigns DIR] [--before DIR]

``--campaigns DIR`` reuses campaigns written by an earlier run (to compare two
versions of the code on the same inputs: run the old one with ``PYTHONPATH=<other
checkout>``, then this one with ``--before <its --out>``).
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pandas as pd

from bench.ingest.pipeline import ingest
from bench.store.read import read_points

ROOT = Path(__file__).resolve().parents[1]
#: relative standard uncertainty of one power reading from the instruments [-]
ACCURACY = 0.002


def write_campaigns(folder: Path) -> None:
    """Write every campaign class into ``folder/<name>/`` (the synthetic ones seeded)."""
    from bench.synth.exports import make_dyno_table, make_ev_table, make_hobby_dyno_table
    from bench.synth.rated_drive import EV_DRIVE, PAPER_DRIVE, grid_points, write_table_campaign

    shutil.copytree(ROOT / "raw_measurements", folder / "raw_measurements")
    make_dyno_table(folder / "dyno_table_N_mm")
    make_ev_table(folder / "ev_export_expr_UI", p_elec_by="expr")
    make_ev_table(folder / "ev_export_sum_of_3", p_elec_by="sum")
    make_hobby_dyno_table(folder / "hobby_dyno_part_load_outlier")
    for name, drive, quadrants, noise in (
            ("rated_motor_only", PAPER_DRIVE, ("motor",), 40.0),
            ("rated_generator_only", PAPER_DRIVE, ("generator",), 40.0),
            ("rated_150kW_non_convex", EV_DRIVE, ("motor", "generator"), 300.0)):
        pts = grid_points(drive, quadrants, noise_w=noise, seed=7)
        write_table_campaign(folder / name, drive, pts)


def efficiency(p_mech, p_elec) -> np.ndarray:
    """Paper eqs. 1-2 (motor P_mech / P_elec, generator P_elec / P_mech)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(p_mech > 0, p_mech / p_elec, p_elec / p_mech)


def uncertainty(pts: pd.DataFrame, eta: np.ndarray, repeat_w=0.0) -> np.ndarray:
    """Standard uncertainty of each point's efficiency [-] (see the module docstring)."""
    n = pts["n_samples"].to_numpy(float) if "n_samples" in pts else np.full(len(pts), np.nan)
    rel = (np.asarray(repeat_w, float) / np.abs(pts["p_elec_w"].to_numpy(float))) ** 2
    for p in ("p_elec", "p_mech"):
        value = np.abs(pts[f"{p}_w"].to_numpy(float))
        std = pts[f"{p}_w_std"].to_numpy(float) if f"{p}_w_std" in pts else np.full(len(pts),
                                                                                     np.nan)
        with np.errstate(invalid="ignore", divide="ignore"):
            se = np.where(n > 0, std / np.sqrt(n), std)
            se = np.where(np.isfinite(se), se, 0.0)
            rel += (np.hypot(se, ACCURACY * value) / value) ** 2
    return np.abs(eta) * np.sqrt(rel)


def map_at(emap: pd.DataFrame, speed: np.ndarray, torque: np.ndarray) -> np.ndarray:
    """Node losses interpolated bilinearly at the points (in-domain nodes only) [W]."""
    s_nodes = np.unique(emap["speed_rpm"].to_numpy())
    t_nodes = np.unique(emap["torque_nm"].to_numpy())
    grid = emap.pivot_table(index="speed_rpm", columns="torque_nm", values="loss_w",
                            aggfunc="first", dropna=False).reindex(index=s_nodes,
                                                                    columns=t_nodes)
    loss = grid.to_numpy(float)
    i = np.clip(np.searchsorted(s_nodes, speed) - 1, 0, s_nodes.size - 2)
    j = np.clip(np.searchsorted(t_nodes, torque) - 1, 0, t_nodes.size - 2)
    fs = np.clip((speed - s_nodes[i]) / (s_nodes[i + 1] - s_nodes[i]), 0.0, 1.0)
    ft = np.clip((torque - t_nodes[j]) / (t_nodes[j + 1] - t_nodes[j]), 0.0, 1.0)
    num, den = np.zeros(speed.size), np.zeros(speed.size)
    for di, dj, w in ((0, 0, (1 - fs) * (1 - ft)), (1, 0, fs * (1 - ft)),
                      (0, 1, (1 - fs) * ft), (1, 1, fs * ft)):
        v = loss[i + di, j + dj]
        ok = np.isfinite(v) & (w > 0)
        num += np.where(ok, w * np.nan_to_num(v), 0.0)
        den += np.where(ok, w, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / den, np.nan)


def evaluate(name: str, campaign: Path, work: Path, before: Path | None = None) -> list[dict]:
    """Ingest and fit one campaign; one row per measured quadrant (``before``: the work
    folder of an earlier run, whose map is read with this run's uncertainties too)."""
    from fitting.pipeline import FitOptions, run_fit

    store, fit = work / name / "store", work / name / "fit"
    ingest([campaign], store, progress=False)
    summary = run_fit(store, fit, FitOptions(), progress=False)
    pts = read_points(store)
    emap = pd.read_parquet(fit / "efficiency_map.parquet")
    nominal = summary["drive"]["nominal_power_w"]
    masking = summary["efficiency"]["masking"]
    p_mech, p_elec = pts["p_mech_w"].to_numpy(float), pts["p_elec_w"].to_numpy(float)
    eta = efficiency(p_mech, p_elec)
    ok = ((np.abs(p_mech) >= masking["mech_frac"] * nominal)
          & (np.abs(p_elec) >= masking["elec_frac"] * nominal) & (eta > 0) & (eta <= 1.0))
    # the fit's pooled loss repeatability per quadrant (0 from a version without one)
    repeat = summary["efficiency"].get("loss_repeatability", {})
    repeat_w = np.where(p_mech > 0, repeat.get("motor", {}).get("loss_w", 0.0),
                        repeat.get("generator", {}).get("loss_w", 0.0))
    u_stated = uncertainty(pts, eta)
    u = uncertainty(pts, eta, repeat_w)
    loss = map_at(emap, pts["speed_rpm"].to_numpy(float), pts["torque_nm"].to_numpy(float))
    old = before / "runs" / name / "fit" if before else None
    if old is not None:
        old_loss = map_at(pd.read_parquet(old / "efficiency_map.parquet"),
                          pts["speed_rpm"].to_numpy(float), pts["torque_nm"].to_numpy(float))
        old_peak = json.loads((old / "fit_summary.json").read_text())["efficiency"]["peak"]
    rows = []
    for q, peak in summary["efficiency"]["peak"].items():
        ceiling = peak["ceiling"]["eta"]
        sel = ok & ((p_mech > 0) if q == "motor" else (p_mech <= 0))
        eta_map = np.minimum(efficiency(p_mech, p_mech + loss), ceiling)
        covered = sel & np.isfinite(eta_map)
        excess = np.where(covered, eta - eta_map - u, -np.inf)
        below = np.where(covered, eta_map - eta - u, -np.inf)
        k = int(np.argmax(np.where(sel, eta, -np.inf)))
        map_peak = peak["map"]["eta"]
        rows.append({
            "campaign": name, "quadrant": q, "points_ok": int(sel.sum()),
            "repeat_w": float(repeat.get(q, {}).get("loss_w", 0.0)),
            "above_grid_stated_u": int((covered & (eta - eta_map > u_stated)).sum()),
            "above_grid": int((excess > 0).sum()),
            "worst_grid_excess": float(excess.max()) if (excess > 0).any() else 0.0,
            "below_grid": int((below > 0).sum()),
            "grid_not_covering": int((sel & ~np.isfinite(eta_map)).sum()),
            "measured_peak": float(eta[k]), "u_peak": float(u[k]),
            "map_peak": map_peak, "ceiling": ceiling,
            "ceiling_below_a_point": bool(ceiling < eta[k]),
            "map_peak_within_u": bool(abs(map_peak - eta[k]) <= u[k] + 1e-12),
            "outliers_flagged": (summary["statistics"].get("outliers") or {}).get("n_flagged"),
        })
        if old is not None:  # the earlier map, read with this run's uncertainties
            old_eta = np.minimum(efficiency(p_mech, p_mech + old_loss),
                                 old_peak[q]["ceiling"]["eta"])
            rows[-1]["before_above_grid_stated_u"] = int(
                (sel & np.isfinite(old_eta) & (eta - old_eta > u_stated)).sum())
            rows[-1]["before_above_grid"] = int(
                (sel & np.isfinite(old_eta) & (eta - old_eta > u)).sum())
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, help="work folder (default: a temporary one)")
    parser.add_argument("--campaigns", type=Path,
                        help="campaigns written by an earlier run (default: write them)")
    parser.add_argument("--before", type=Path,
                        help="work folder of an earlier run (another version of the code): "
                             "its maps read with this run's point uncertainties")
    args = parser.parse_args()
    work = args.out or Path(tempfile.mkdtemp(prefix="map_honesty_"))
    campaigns = args.campaigns or work / "campaigns"
    if args.campaigns is None:
        write_campaigns(campaigns)
    rows = [r for c in sorted(p for p in campaigns.iterdir() if p.is_dir())
            for r in evaluate(c.name, c, work / "runs", args.before)]
    table = pd.DataFrame(rows)
    with pd.option_context("display.width", 250, "display.max_columns", 20,
                           "display.float_format", "{:.4f}".format):
        print(table.to_string(index=False))
    (work / "map_honesty.json").write_text(json.dumps(rows, indent=1))
    print(f"campaigns: {campaigns}\nwork folder: {work}")


if __name__ == "__main__":
    main()
