"""The annual-energy assessment of one optimize run at one site: the library behind ``bench aep``.

For each scenario kind (objective x drive limits) it gives the electrical and
mechanical AEP, the capacity factors against the drive's nominal power, the
95 % band of the electrical AEP from the power model's coefficient covariance
(:mod:`energy.bands`) and, when given, from the site parameters' uncertainty;
and the loss split: what the drive's efficiency costs (mechanical minus
electrical AEP of the same cycles) and what its limits cost (AEP without
limits minus AEP with them, same objective).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from energy import aep as aep_mod
from energy import bands
from energy.curve import OptimizeRun, PowerCurve
from energy.site import Distribution, Histogram, Weibull
from kernel.drive import Drive
from kernel.errors import InputError
from kernel.files import read_json
from kernel.output_folder import check_output_file
from optimize.door import OBJECTIVES, kind_of
from optimize.sweep_folder import read_trajectories

#: the trajectory columns the coefficient bands need (cycle averages of the model terms)
CYCLE_COLUMNS = ("scenario", "kind", "wind_speed_m_s", "weight", "speed_rpm", "torque_nm")

#: where the nominal power (the capacity factor's rating) is taken from, in this order
NOMINAL_SOURCES = ("--nominal-power-w",
                   "the drive in force (optimize manifest sections.drive.nominal_power_w)",
                   "power_model.json drive.nominal_power_w", "power_model.json nominal_power_w")


@dataclass(frozen=True)
class SiteUncertainty:
    """One-sigma uncertainty of the site parameters (Weibull sites only).

    Attributes
    ----------
    mean_m_s : float
        Of the mean wind speed at the reference height [m/s].
    k : float
        Of the Weibull shape [-].
    """

    mean_m_s: float = 0.0
    k: float = 0.0


def _positive_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) \
        and math.isfinite(value) and value > 0


def nominal_power(model_json: dict | None, override_w: float | None, path: Path | None,
                  in_force: Drive | None = None) -> tuple[float, str]:
    """The drive's nominal power [W] and where it came from.

    Order: the user's ``override_w``; the nominal power of the drive in force
    ``in_force`` (the optimize manifest's ``sections.drive``: the system's drive,
    :attr:`energy.curve.OptimizeRun.drive`); ``drive.nominal_power_w`` of the power model
    file; its top-level ``nominal_power_w`` (schema version 1).
    """
    if override_w is not None:
        if not (math.isfinite(override_w) and override_w > 0):
            raise InputError(None, f"--nominal-power-w {override_w}", expected="a power > 0 W")
        return float(override_w), NOMINAL_SOURCES[0]
    if in_force is not None and _positive_number(in_force.nominal_power_w):
        return float(in_force.nominal_power_w), NOMINAL_SOURCES[1]
    model_json = model_json or {}
    drive = model_json.get("drive")
    if isinstance(drive, dict) and _positive_number(drive.get("nominal_power_w")):
        return float(drive["nominal_power_w"]), NOMINAL_SOURCES[2]
    value = model_json.get("nominal_power_w")
    if _positive_number(value):
        return float(value), NOMINAL_SOURCES[3]
    raise InputError(path, "no nominal power (drive.nominal_power_w or nominal_power_w)",
                     expected="give --nominal-power-w")


def _weibull_site_sigma(curve_fn, dist: Weibull, unc: SiteUncertainty) -> float:
    """One-sigma AEP [MWh/yr] from independent site-parameter errors (central differences)."""
    var = 0.0
    mean, k = dist.mean_m_s, dist.k
    for name, s in (("mean", unc.mean_m_s), ("k", unc.k)):
        if s <= 0:
            continue
        h = 1e-3 * (mean if name == "mean" else k)
        if name == "mean":
            hi, lo = Weibull.from_mean(k, mean + h), Weibull.from_mean(k, mean - h)
        else:
            hi, lo = Weibull.from_mean(k + h, mean), Weibull.from_mean(k - h, mean)
        var += ((curve_fn(hi) - curve_fn(lo)) / (2 * h) * s) ** 2
    return math.sqrt(var)


@dataclass(frozen=True)
class KindEnergy:
    """Energy figures of one scenario kind at the site (see :func:`assess`)."""

    kind: str
    objective: str
    drive_limits: bool
    elec: aep_mod.CurveEnergy
    mech: aep_mod.CurveEnergy
    sigma_elec_model_mwh: float | None
    sigma_elec_site_mwh: float
    n_points: int
    failed: tuple[tuple[float, str], ...]

    @property
    def efficiency_loss_mwh(self) -> float:
        """Mechanical minus electrical AEP of the same cycles [MWh/yr]: the drive's losses."""
        return self.mech.aep_mwh - self.elec.aep_mwh

    @property
    def sigma_elec_mwh(self) -> float | None:
        """Combined one-sigma electrical AEP (model and site, independent) [MWh/yr]."""
        if self.sigma_elec_model_mwh is None:
            return None
        return math.hypot(self.sigma_elec_model_mwh, self.sigma_elec_site_mwh)


@dataclass(frozen=True)
class Assessment:
    """Everything ``bench aep`` computes; :mod:`energy.outputs` writes it."""

    site: Distribution
    site_note: str
    nominal_power_w: float
    nominal_source: str
    kinds: dict[str, KindEnergy]
    curves: pd.DataFrame
    notes: tuple[str, ...] = field(default=())

    def limit_loss_mwh(self, objective: str, quantity: str) -> float | None:
        """AEP without minus with the drive limits, same objective [MWh/yr], or None."""
        lim, free = (self.kinds.get(kind_of(objective, limits).key) for limits in (True, False))
        if lim is None or free is None:
            return None
        return getattr(free, quantity).aep_mwh - getattr(lim, quantity).aep_mwh

    def table(self) -> pd.DataFrame:
        """One row per kind: AEP, capacity factor, band, losses (the report's AEP table)."""
        rows = []
        for k in self.kinds.values():
            quantity = OBJECTIVES[k.objective].short
            lim_loss = self.limit_loss_mwh(k.objective, quantity) if k.drive_limits else None
            rows.append({
                "kind": k.kind, "objective": k.objective, "drive_limits": k.drive_limits,
                "aep_elec_mwh": k.elec.aep_mwh, "aep_mech_mwh": k.mech.aep_mwh,
                "capacity_factor_elec": k.elec.capacity_factor,
                "capacity_factor_mech": k.mech.capacity_factor,
                "sigma_aep_elec_model_mwh": k.sigma_elec_model_mwh,
                "sigma_aep_elec_site_mwh": k.sigma_elec_site_mwh,
                # delivered energy is >= 0: the linear band is cut at 0 near a clipped curve
                "ci95_aep_elec_low_mwh": (None if k.sigma_elec_mwh is None
                                          else max(0.0, k.elec.aep_mwh
                                                   - bands.Z95 * k.sigma_elec_mwh)),
                "ci95_aep_elec_high_mwh": (None if k.sigma_elec_mwh is None
                                           else k.elec.aep_mwh + bands.Z95 * k.sigma_elec_mwh),
                "efficiency_loss_mwh": k.efficiency_loss_mwh,
                "limit_loss_mwh": lim_loss,
                "cut_in_elec_m_s": k.elec.cut_in_m_s, "cut_out_elec_m_s": k.elec.cut_out_m_s,
                "share_below_grid": k.elec.share_below_grid,
                "share_above_grid": k.elec.share_above_grid,
                "grid_min_m_s": k.elec.grid_m_s[0], "grid_max_m_s": k.elec.grid_m_s[1],
                "share_left_out": k.elec.share_left_out,
                "energy_below_grid": k.elec.energy_below_grid,
                "energy_above_grid": k.elec.energy_above_grid,
                "energy_left_out": k.elec.energy_left_out,
                "delivers_at_grid_start": k.elec.delivers_at_grid_start,
                "n_points": k.n_points,
            })
        return pd.DataFrame(rows)


def model_for_run(run: OptimizeRun, drive_model: Path | None) -> tuple[Path | None, dict | None]:
    """The power model file of the sweep (or ``drive_model``) and its decoded JSON."""
    path = Path(drive_model) if drive_model is not None else run.drive_model_path
    if path is None or not path.is_file():
        return path, None
    check_output_file(path)  # a fit folder must be the whole output of one run
    return path, read_json(path, what="power model file")


def assess(run: OptimizeRun, site: Distribution, site_note: str, *,
           drive_model: Path | None = None, nominal_power_w: float | None = None,
           site_uncertainty: SiteUncertainty | None = None,
           gradients: dict | None = None) -> Assessment:
    """Annual energy, bands and losses of every scenario kind of ``run`` at ``site``.

    Parameters
    ----------
    run : OptimizeRun
        From :func:`energy.curve.read_optimize_run`.
    site : Weibull or Histogram
        Wind-speed distribution at the optimize stage's reference height.
    site_note : str
        How the site was given (for the outputs).
    drive_model : Path, optional
        Power model file; default the one the sweep's manifest names. Its
        covariance gives the model band; it must be the model the sweep used
        (checked against the manifest's hash), else no band is given.
    nominal_power_w : float, optional
        Overrides the model file's nominal power [W].
    site_uncertainty : SiteUncertainty, optional
        One-sigma site-parameter errors (Weibull sites).
    gradients : dict, optional
        Scenario -> basis averages of points with no stored trajectory (added by
        :mod:`energy.refine`).
    """
    notes: list[str] = []
    path, model_json = model_for_run(run, drive_model)
    nominal, source = nominal_power(model_json, nominal_power_w, path, run.drive)
    model = _band_model(run, path, model_json, notes)
    if site_uncertainty and (site_uncertainty.mean_m_s > 0 or site_uncertainty.k > 0) and \
            isinstance(site, Histogram):
        raise InputError(None, "--mean-sigma/--k-sigma: site-parameter uncertainty given for a "
                         "histogram site (--histogram)",
                         expected="--mean-sigma/--k-sigma only with a Weibull or Rayleigh site")
    trajectories = (read_trajectories(run.folder, CYCLE_COLUMNS) if model is not None
                    else None)
    kinds: dict[str, KindEnergy] = {}
    curve_rows = []
    for kind, curve in run.curves.items():
        if len(np.unique(curve.wind_speed_m_s)) < 2:
            raise InputError(run.folder / "summary.parquet",
                             f"kind {kind}: a power curve of {len(curve.wind_speed_m_s)} converged "
                             "wind speed cannot be integrated over the site's wind hours",
                             expected="a sweep of at least two wind speeds that converge "
                                      "(bench optimize --wind-grid LO:HI:STEP)")
        kinds[kind], rows = _kind_energy(curve, site, nominal, model, trajectories, gradients,
                                         site_uncertainty, notes)
        curve_rows += rows
    if not kinds:
        raise InputError(run.folder / "summary.parquet", "no converged scenario",
                         expected="at least one converged scenario per curve")
    notes += coverage_notes(kinds.values())
    return Assessment(site, site_note, nominal, source, kinds, pd.DataFrame(curve_rows),
                      tuple(notes))


def coverage_notes(kinds) -> list[str]:
    """What the grid leaves out of the site, in words: the hours and the share of the
    site's available wind energy below its first speed where a kind already delivers
    there (its cut-in lies below the grid, so those hours are an undercount), and above
    its last speed when more than :data:`energy.site.ENERGY_LEFT_OUT` of the energy lies
    there."""
    from energy.site import ENERGY_LEFT_OUT

    kinds = list(kinds)
    notes = []
    low = [k for k in kinds if k.elec.delivers_at_grid_start]
    if low:
        e = low[0].elec
        notes.append(
            f"{', '.join(k.kind for k in low)} already deliver at the grid's first speed "
            f"{e.grid_m_s[0]:g} m/s: the cut-in lies below the grid and was not found, and "
            f"the {e.share_below_grid:.1%} of the hours below it ({e.energy_below_grid:.1%} of "
            "the site's wind energy) count as zero power: the AEP is an undercount; start "
            "--wind-grid lower to count them")
    top = max(kinds, key=lambda k: k.elec.energy_above_grid)
    if top.elec.energy_above_grid > ENERGY_LEFT_OUT:
        e = top.elec
        notes.append(f"{e.share_above_grid:.1%} of the hours ({e.energy_above_grid:.1%} of the "
                     f"site's wind energy) have wind above the last grid point "
                     f"{e.grid_m_s[1]:g} m/s and count with zero power (cut-out at the grid's "
                     "end): extend --wind-grid to count them")
    return notes


def _band_model(run: OptimizeRun, path: Path | None, model_json: dict | None,
                notes: list[str]) -> Any:
    """The power model whose covariance gives the bands, or None (with a note why)."""
    from fitting.model_schema import power_model_from_dict

    if model_json is None:
        notes.append(f"power model {path} not found: no confidence band")
        return None
    model = power_model_from_dict(model_json, path)
    if run.drive_model_sha256 and model.sha256 != run.drive_model_sha256:
        notes.append(f"{path} is not the model the sweep used (hash differs from the "
                     "optimize manifest): no confidence band")
        return None
    if model.covariance_rpm is None:
        notes.append(f"{path} carries no coefficient covariance: no confidence band")
        return None
    return model


def _kind_energy(curve: PowerCurve, site: Distribution, nominal: float, model: Any,
                 trajectories: pd.DataFrame | None, gradients: dict | None,
                 site_uncertainty: SiteUncertainty | None,
                 notes: list[str]) -> tuple[KindEnergy, list[dict]]:
    """One kind's energy and bands, and its rows of ``power_curves.csv``."""
    elec = aep_mod.curve_energy(curve.wind_speed_m_s, curve.p_elec_w, site, nominal,
                                curve.cut_in_m_s)
    mech = aep_mod.curve_energy(curve.wind_speed_m_s, curve.p_mech_w, site, nominal, None)
    sigma_p = np.full(len(curve.wind_speed_m_s), np.nan)
    sigma_model = None
    if model is not None:
        grads = bands.curve_gradients(trajectories, curve.scenarios, model, gradients)
        _check_consistent(curve, grads, model, notes)
        sigma_p = np.array([model.sigma_of_basis(g) for g in grads])
        dA = aep_mod.aep_sensitivity(curve.wind_speed_m_s, curve.p_elec_w, site, curve.cut_in_m_s)
        sigma_model = model.sigma_of_basis(dA @ grads)
    sigma_site = 0.0
    if site_uncertainty is not None and isinstance(site, Weibull):
        sigma_site = _weibull_site_sigma(
            lambda d, c=curve: aep_mod.aep_mwh(c.wind_speed_m_s, c.p_elec_w, d, c.cut_in_m_s),
            site, site_uncertainty)
    if curve.failed:
        notes.append(f"{curve.kind}: failed solves at "
                     f"{', '.join(f'{w:g}' for w, _ in curve.failed)}"
                     " m/s are left out; the curve is interpolated across them")
    energy = KindEnergy(curve.kind, curve.objective, curve.drive_limits, elec, mech,
                        sigma_model, sigma_site, len(curve.wind_speed_m_s), curve.failed)
    rows = [{"kind": curve.kind, "scenario": curve.scenarios[i], "wind_speed_m_s": float(v),
             "p_elec_w": float(curve.p_elec_w[i]), "p_mech_w": float(curve.p_mech_w[i]),
             "p_elec_sigma_w": float(sigma_p[i]),
             "added": bool(curve.added[i]) if curve.added else False}
            for i, v in enumerate(curve.wind_speed_m_s)]
    return energy, rows


def _check_consistent(curve: PowerCurve, grads: np.ndarray, model, notes: list[str]) -> None:
    """The model applied to the basis averages must give the summary's average power."""
    p = model.of_basis(grads)
    err = np.max(np.abs(p - curve.p_elec_w))
    if err > 1e-3 * max(1.0, float(np.max(np.abs(curve.p_elec_w)))):
        notes.append(f"{curve.kind}: the model on the stored trajectories differs from the "
                     f"summary's average electrical power by up to {err:.1f} W: the band may "
                     "belong to another model")
