"""``bench fit``: efficiency map, power model fit, model selection, export.

Parses the options into :class:`fitting.pipeline.FitOptions`, runs the fit
(:func:`fitting.pipeline.run_fit`) and prints its summary.
"""

from __future__ import annotations

import argparse

from fitting.domain import BAND_FRAC
from fitting.pipeline import WEIGHTINGS, FitOptions
from kernel.drive import DRIVE_KEYS, Drive
from kernel.errors import InputError


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the ``bench fit`` options."""
    parser.add_argument("--store", default="bench_store", help="store written by bench ingest")
    parser.add_argument("--out", default="fit_out", help="output folder")
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--order", default="2",
                       help="total order 1..6 of the exported model, or 'auto' to select it; "
                            "order 2 is the paper's eq. 4 unless --full (default: 2)")
    group.add_argument("--select", action="store_true", help="same as --order auto")
    parser.add_argument("--full", action="store_true",
                        help="with --order 2: the full 6-term quadratic instead of eq. 4")
    parser.add_argument("--folds", type=int, default=5, help="k of k-fold cross-validation")
    parser.add_argument("--weighting", choices=WEIGHTINGS, default="quadrant",
                        help="'quadrant': each quadrant counts equally whatever its point "
                             "count (default); 'none': plain OLS")
    parser.add_argument("--mask-mech-frac", type=float, default=FitOptions.mask_mech_frac,
                        help="mask efficiencies where |P_mech| < F * nominal power")
    parser.add_argument("--mask-elec-frac", type=float, default=FitOptions.mask_elec_frac,
                        help="mask efficiencies where |P_elec| < F * nominal power")
    parser.add_argument("--envelope-band-frac", type=float, default=BAND_FRAC,
                        help="speed band of the measured envelope, a fraction of the largest "
                             "|speed| (default: %(default)s)")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    rating = parser.add_argument_group(
        "drive rating (default: the campaign's drive.toml / session.toml, as ingested)")
    rating.add_argument("--nominal-power-w", type=float, help="nominal power [W]")
    rating.add_argument("--max-speed-rpm", type=float, help="largest drum speed [rpm]")
    rating.add_argument("--max-torque-nm", type=float, help="largest drum torque [N m]")


def _order(text: str, select: bool) -> int | None:
    if select or text.strip().lower() == "auto":
        return None
    try:
        return int(text)
    except ValueError:
        raise InputError(None, f"option --order: {text!r} is not an integer",
                         expected="an order 1..6 or 'auto'") from None


def run(args: argparse.Namespace) -> int:
    """Run the fit (:func:`fitting.pipeline.run_fit`) and print its summary."""
    from fitting.pipeline import FitOptions, run_fit

    order = _order(args.order, args.select)
    drive = {k: getattr(args, k) for k in DRIVE_KEYS if getattr(args, k) is not None}
    rating_args = [a for k, v in drive.items() for a in (f"--{k.replace('_', '-')}", repr(v))]
    command_line = (
        "bench", "fit", "--store", str(args.store), "--out", str(args.out),
        "--order", "auto" if order is None else str(order), *(["--full"] if args.full else []),
        "--folds", str(args.folds), "--weighting", args.weighting,
        "--mask-mech-frac", repr(args.mask_mech_frac),
        "--mask-elec-frac", repr(args.mask_elec_frac),
        "--envelope-band-frac", repr(args.envelope_band_frac), *rating_args,
    )
    options = FitOptions(order=order, full_order2=args.full, folds=args.folds,
                         weighting=args.weighting, mask_mech_frac=args.mask_mech_frac,
                         mask_elec_frac=args.mask_elec_frac,
                         envelope_band_frac=args.envelope_band_frac, drive=drive,
                         command_line=command_line)
    print(format_summary(run_fit(args.store, args.out, options,
                                        progress=not args.no_progress), args.out))
    return 0


def format_summary(summary: dict, out) -> str:
    """The short text summary printed by ``bench fit``."""
    lines = [*_model_lines(summary), *_selection_lines(summary), *_efficiency_lines(summary),
             f"outputs in {out}: " + ", ".join(summary["outputs"][:6]) + ", figures/..."]
    return "\n".join(lines)


def _model_lines(summary: dict) -> list[str]:
    """The model, the points, the drive, the notes, the coefficients and the residuals."""
    st = summary["statistics"]
    drive = Drive.from_dict(summary["drive"], where="fit summary drive", rating=True)
    lines = [f"model: {summary['model']['name']}  (sha256 {summary['model']['sha256'][:12]})",
             f"points: {st['n_points']} {st['points_per_quadrant']}  fit: {st['method']}",
             drive.line(),
             *(f"note: {n}" for n in summary["notes"]),
             "",
             f"{'term':>10} {'coef [rpm, N m, W]':>20} {'std error':>12} {'95 % interval':>29}"]
    for row in st["coefficients"]:
        lines.append(f"{row['term']:>10} {row['coef_rpm']:>20.6g} {row['std_error_rpm']:>12.3g} "
                     f"[{row['ci95_low_rpm']:>12.6g}, {row['ci95_high_rpm']:>12.6g}]")
    res = st["residuals"]["all"]
    lines += [
        "",
        f"R^2 = {st['r2']:.6f}",
        f"residuals: mean {res['mean_w']:.2f} W, std {res['std_w']:.1f} W "
        f"({res['std_pct_nominal']:.2f} % of nominal), max |r| {res['max_abs_w']:.1f} W "
        f"({res['max_abs_pct_nominal']:.2f} % of nominal)",
    ]
    norm = st["normality"]
    if "dagostino_k2" in norm:
        lines.append(f"normality: D'Agostino K^2 p = {norm['dagostino_k2']['p_value']:.3g}, "
                     f"Jarque-Bera p = {norm['jarque_bera']['p_value']:.3g} -> "
                     + ("consistent with normal" if norm["normal_at_5pct"]
                        else "not normal at 5 %"))
    return lines


def _selection_lines(summary: dict) -> list[str]:
    """The candidates' table, the choice and the paper's extra-terms check."""
    st = summary["statistics"]
    lines: list[str] = []
    lines += ["", f"{'candidate':>20} {'terms':>5} {'CV RMSE [W]':>12} {'+-SE':>6} "
              f"{'dBIC':>8}  status"]
    for row in summary["selection_table"]:
        if row["status"] == "ok":
            lines.append(f"{row['candidate']:>20} {row['n_terms']:>5} {row['cv_rmse_w']:>12.1f} "
                         f"{row['cv_rmse_se_w']:>6.1f} {row['delta_bic']:>8.1f}  "
                         + ("<- chosen" if row["chosen"] else ""))
        else:
            lines.append(f"{row['candidate']:>20} {row['n_terms']:>5}  {row['status']}")
    sel = st["selection"]
    lines += [f"selection: {sel['reason']}",
              f"exported: {sel['exported']} ({sel['exported_because']})"]
    extra = summary["extra_terms_check"]
    if "paper_terms" in extra:
        lines.append("extra terms (fit over w^6 T^4): "
                     + "; ".join(f"{name}: {r['raw_orders_below_a1']:.1f} orders below a1 "
                                 f"(raw rpm), {r['rated_orders_below_a1']:.1f} at rated corner"
                                 for name, r in extra["paper_terms"].items())
                     + f"; wide vs eq. 4 model differ by at most "
                       f"{extra['model_difference']['max_abs_w']:.0f} W at the points")
    return lines


def _efficiency_lines(summary: dict) -> list[str]:
    """The map's area shares per band, its peaks and how it shows the points."""
    lines: list[str] = []
    shares: dict[str, list[str]] = {}
    for row in summary["efficiency"]["band_shares"]:
        if row["area_share"]:
            shares.setdefault(row["quadrant"], []).append(
                f"{row['band']} {100 * row['area_share']:.0f} %")
    for q, parts in shares.items():
        lines.append(f"area share per efficiency band, {q}: " + ", ".join(parts))
    for q, peak in summary["efficiency"]["peak"].items():
        if "map" in peak:
            m = peak["map"]
            line = (f"peak efficiency {q}: {m['eta']:.3f} at {_num(m['speed_rpm'])} rpm, "
                    f"{_num(m['torque_nm'])} N m (map)")
            if "measured" in peak:
                line += f"; measured max {peak['measured']['eta']:.3f}"
            c = peak.get("ceiling")
            if c:
                line += (f"; ceiling {c['eta']:.3f} (measured max + its uncertainty "
                         f"{c['noise_eta']:.3f})")
                if c["n_clipped_nodes"]:
                    line += f", {c['n_clipped_nodes']} map nodes clipped to it"
            lines.append(line)
    repeat = summary["efficiency"].get("loss_repeatability", {})
    for q, a in summary["efficiency"].get("points_against_map", {}).items():
        r = repeat.get(q, {})
        lines.append(
            f"map against the points, {q}: {a['n_above_map']} of {a['n_points']} above it "
            f"by more than their uncertainty, {a.get('n_below_map', 0)} below it, "
            f"{a['n_off_map']} off the grid; loss repeatability {r.get('loss_w', 0.0):.3g} W "
            f"({r.get('n_pairs', 0)} repeat pairs, pooled over {r.get('pooled_over', 'none')})")
    return lines


def _num(x: float) -> str:
    """A speed or torque for a summary line: 4 significant digits below 1000, whole above
    (0.32 N m stays 0.32, not 0)."""
    return f"{x:.4g}" if abs(x) < 1000 else f"{x:.0f}"
