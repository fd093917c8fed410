"""The files of ``bench aep`` (docs/schemas.md §7), written atomically.

* ``aep.json``: site, nominal power, the AEP table per scenario kind, losses, notes;
* ``power_curves.csv``: every converged grid point of every kind with its band;
* ``awesio/<kind>_<electrical|mechanical>.yml``: the curves in awesIO's layout.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd

from energy import awesio
from energy.assess import Assessment
from energy.bands import Z95
from energy.curve import OptimizeRun
from energy.site import Shear
from kernel.errors import InputError
from kernel.files import read_csv, read_document, write_json, write_text_atomic
from kernel.output_folder import output_folder
from kernel.provenance import HEADER_KEY, Provenance

SCHEMA_NAME = "drivebench.aep"
SCHEMA_VERSION = 1
AEP_FILE, CURVES_FILE = "aep.json", "power_curves.csv"
_EXPECTED = "the output of `bench aep` (docs/schemas.md §7)"
#: the columns of ``power_curves.csv`` its readers rely on (the report's curve figure)
POWER_CURVE_COLUMNS = ("kind", "wind_speed_m_s", "p_elec_w", "p_mech_w", "p_elec_sigma_w")
SIGN_NOTE = ("AEP and capacity factors are energy delivered (positive MWh/yr): to the grid for "
             "electrical, by the drum shaft for mechanical. Powers in power_curves.csv keep the "
             "optimize sign (negative = generated).")
INTERPOLATION_NOTE = (
    "Delivered power -P is linear between converged grid points, zero where the optimal cycle "
    "would draw power (the zero crossing at the optimize stage's bisected cut-in when found), "
    "and zero below the first and above the last grid point; the expectation over the "
    "distribution is exact for that curve (CDF and first partial moment)."
)


def _clean(value):
    if isinstance(value, dict):
        return {k: _clean(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_clean(v) for v in value]
    if isinstance(value, float | np.floating):
        return float(value) if math.isfinite(value) else None
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    return value


#: files by which an aep output folder written before run ids is known; the resumable
#: store of ``--refine`` solves kept from run to run
AEP_MARKERS, AEP_KEEP = (AEP_FILE,), ("solves",)


def aep_document(a: Assessment, run: OptimizeRun, provenance: Provenance,
                 reference_height_m: float, refine: dict | None = None) -> dict:
    """The ``aep.json`` content (docs/schemas.md §7)."""
    table = a.table()
    return _clean({
        "schema": SCHEMA_NAME,
        "schema_version": SCHEMA_VERSION,
        HEADER_KEY: provenance.header(),
        "optimize": {"folder": str(run.folder),
                     "drive_model": run.manifest.get("drive_model"),
                     "wind_speeds_m_s": run.manifest.get("wind_speeds_m_s")},
        "site": {**a.site.to_dict(), "note": a.site_note,
                 "reference_height_m": reference_height_m},
        "hours_per_year": 8760.0,
        "nominal_power_w": a.nominal_power_w,
        "nominal_power_source": a.nominal_source,
        "sign_convention": SIGN_NOTE,
        "interpolation": INTERPOLATION_NOTE,
        "band": f"95 % two-sided normal interval, z = {Z95:.3f}; model and site sigmas combined "
                "in quadrature; errors fully correlated along the wind grid",
        "kinds": table.to_dict(orient="records"),
        "losses": {
            "limits_elec_objective_mwh": a.limit_loss_mwh("electrical", "elec"),
            "limits_mech_objective_mech_mwh": a.limit_loss_mwh("mechanical", "mech"),
            "efficiency_by_kind_mwh": {k: v.efficiency_loss_mwh for k, v in a.kinds.items()},
        },
        "refine": refine,
        "notes": list(a.notes),
        "files": {"curves": CURVES_FILE, "awesio": sorted(_awesio_names(a))},
    })


def _awesio_names(a: Assessment) -> list[str]:
    return [f"awesio/{k}_{q}.yml" for k in a.kinds for q in ("electrical", "mechanical")]


def write_outputs(a: Assessment, run: OptimizeRun, out: Path, provenance: Provenance,
                  shear: Shear, refine: dict | None = None) -> dict[str, Path]:
    """:func:`write_files` into ``out``, all or none (:mod:`kernel.output_folder`);
    ``out/solves`` (the ``--refine`` store) is kept."""
    with output_folder(out, "aep", AEP_MARKERS, keep=AEP_KEEP, provenance=provenance) as stage:
        files = write_files(a, run, stage, provenance, shear, refine)
    return {k: Path(out) / Path(v).relative_to(stage) for k, v in files.items()}


def write_files(a: Assessment, run: OptimizeRun, out: Path, provenance: Provenance,
                shear: Shear, refine: dict | None = None) -> dict[str, Path]:
    """Write ``aep.json``, ``power_curves.csv`` and the awesIO files into ``out``.

    ``refine`` is the ``refine`` object of ``aep.json`` (:func:`energy.refine.refine_document`)
    when the curves were refined; ``run`` then carries the refined curves.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    files = {}
    curves = a.curves.copy()
    curves["p_elec_ci95_low_w"] = curves["p_elec_w"] - Z95 * curves["p_elec_sigma_w"]
    curves["p_elec_ci95_high_w"] = curves["p_elec_w"] + Z95 * curves["p_elec_sigma_w"]
    files["curves"] = write_text_atomic(out / CURVES_FILE,
                                        curves.to_csv(index=False, float_format="%.6g"))
    altitudes = np.arange(0.0, 501.0, 10.0)
    reference_height_m = shear.reference_height_m
    v_ref = shear.profile(reference_height_m)
    u = np.array([shear.profile(h) / v_ref if h > 0 else 0.0 for h in altitudes])
    model = run.manifest.get("drive_model") or {}
    for kind, curve in run.curves.items():
        for q, p in (("electrical", curve.p_elec_w), ("mechanical", curve.p_mech_w)):
            doc = awesio.power_curve_document(
                name=f"drivebench {kind} {q}",
                description=f"Optimal pumping-cycle average {q} power, scenario kind {kind} "
                            f"({curve.objective} objective, drive limits "
                            f"{'on' if curve.drive_limits else 'off'})",
                note=f"average_cycle_power is the {q} power delivered (positive = generated) "
                     f"[W], wind at {reference_height_m:g} m, {shear.describe()}. Failed solves "
                     "are left out"
                     + ("; wind speeds added by bench aep --refine are in the list."
                        if any(curve.added) else "."),
                wind_speed_m_s=curve.wind_speed_m_s, delivered_w=-p, cycle_time_s=curve.period_s,
                reference_height_m=reference_height_m, altitudes_m=altitudes, u_normalized=u,
                model_config={"drive_model": model.get("name"),
                              "drive_model_sha256": model.get("model_sha256"),
                              "optimize_folder": str(run.folder)},
            )
            name = f"awesio/{kind}_{q}.yml"
            files[name] = write_text_atomic(out / name, awesio.dump_yaml(doc) + "\n")
    files["aep"] = write_json(
        out / AEP_FILE, aep_document(a, run, provenance, reference_height_m, refine),
        non_finite="error")
    return files


def read_aep(folder: Path) -> dict:
    """The ``aep.json`` of an aep output folder, its schema checked."""
    return read_document(Path(folder) / AEP_FILE, SCHEMA_NAME, expected=_EXPECTED)


def read_power_curves(folder: Path) -> pd.DataFrame:
    """The ``power_curves.csv`` of an aep output folder, the columns of
    :data:`POWER_CURVE_COLUMNS` checked and their numbers read (an empty cell: NaN).

    Raises
    ------
    InputError
        The file is missing or not CSV, lacks a column, or holds text where a number goes.
    """
    path = Path(folder) / CURVES_FILE
    curves = read_csv(path, POWER_CURVE_COLUMNS, expected=_EXPECTED)
    for column in POWER_CURVE_COLUMNS[1:]:
        numbers = pd.to_numeric(curves[column].replace("", np.nan), errors="coerce")
        bad = numbers.isna() & (curves[column] != "")
        if bad.any():
            row = int(np.flatnonzero(bad)[0])
            raise InputError(path, f"{curves[column].iloc[row]!r} is not a number",
                             line=row + 2, column=column, expected="a number or an empty cell")
        curves[column] = numbers.astype(float)
    return curves


def format_table(a: Assessment) -> str:
    """The AEP table as plain text for the terminal."""
    t = a.table()
    lines = [f"{'kind':<10} {'AEP el MWh/yr':>13} {'95% band':>17} {'AEP mech':>9} "
             f"{'CF el':>6} {'CF mech':>7} {'eff. loss':>9} {'limit loss':>10} "
             f"{'cut-in m/s':>10} {'wind energy left out below + above':>34}"]
    for r in t.itertuples(index=False):
        band = ("n/a" if pd.isna(r.ci95_aep_elec_low_mwh)
                else f"{r.ci95_aep_elec_low_mwh:.3f}-{r.ci95_aep_elec_high_mwh:.3f}")
        lim = "" if pd.isna(r.limit_loss_mwh) else f"{r.limit_loss_mwh:.3f}"
        lines.append(f"{r.kind:<10} {r.aep_elec_mwh:>13.3f} {band:>17} {r.aep_mech_mwh:>9.3f} "
                     f"{r.capacity_factor_elec:>6.1%} {r.capacity_factor_mech:>7.1%} "
                     f"{r.efficiency_loss_mwh:>9.3f} {lim:>10} {cut_in_text(r._asdict()):>10} "
                     f"{left_out_text(r._asdict()):>34}")
    return "\n".join(lines)


def cut_in_text(row: dict) -> str:
    """A kind's electrical cut-in for a table: the speed where its delivered power turns
    positive inside the grid, ``below 6`` when it delivers at the grid's first speed
    already (not found), ``none`` when it never delivers."""
    cut = row.get("cut_in_elec_m_s")
    if cut is not None and not pd.isna(cut):
        return f"{cut:.2f}"
    if row.get("delivers_at_grid_start"):
        return f"below {row.get('grid_min_m_s'):g}"
    return "none"


def left_out_text(row: dict) -> str:
    """The share of the site's available wind energy an AEP row leaves out, below and
    above its grid (below only where the kind delivers at the grid's first speed)."""
    below = row.get("energy_below_grid") if row.get("delivers_at_grid_start") else 0.0
    return f"{100 * (below or 0.0):.1f} % + {100 * (row.get('energy_above_grid') or 0.0):.1f} %"
