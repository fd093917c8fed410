"""The files of ``bench optimize`` (docs/schemas.md §5), written atomically.

* ``summary.parquet``: one row per scenario, failed ones included with their
  solver status and NaN metrics;
* ``trajectories.parquet``: every collocation point of every converged
  scenario (states, controls, drive quantities), with the scenario name;
* ``manifest.json``: wind list, kinds, drive-model hash, options, executor,
  package versions, command line, cut-in searches, trust checks;
* ``claims.csv``: the comparison with the paper (:mod:`optimize.analysis.claims`).

Every Parquet field carries its unit in the field metadata (``{"unit": ...}``),
derived from the unit suffix of the column name (:func:`bench.units.unit_of`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from bench.errors import InputError
from fitting.domain import domain_excursion
from optimize.model import kite_model as km
from optimize.service.local_optima import better_margin_w
from optimize.service.outcome import ScenarioOutcome
from optimize.service.solver import cycle_metrics
from optimize.solve.result import OUTPUT_UNITS

SCHEMA_NAME = "drivebench.optimize"
SCHEMA_VERSION = 1

#: summary columns, in order, with their meaning (unit from the name)
SUMMARY_COLUMNS: dict[str, str] = {
    "scenario": "scenario name, kind and wind speed",
    "kind": "elec-lim | elec-free | mech-lim | mech-free",
    "objective": "electrical | mechanical (the average power maximized)",
    "drive_limits": "the drive's speed and torque limits applied (manifest drive_limits)",
    "wind_speed_m_s": "wind speed at 100 m",
    "success": "final solve converged",
    "status": "IPOPT return status of the final solve",
    "result_check": "the physical check of a converged optimum (power against the Loyd-type "
    "bound, collocation error and periodicity of a finer re-integration): 'passed', or "
    "'failed: <reasons>' (then success is false whatever the solver said); '' when not "
    "checked",
    "iterations": "IPOPT iterations of the final solve",
    "wall_time_s": "wall time of the final solve",
    "attempts": "solver runs (retries included)",
    "total_wall_time_s": "wall time of all runs of this scenario",
    "warm_source": "scenario the final solve was warm-started from, or 'cold start'",
    "chain": "warm-start chain (worker task) index",
    "resolved_from": "neighbouring scenarios of the same kind this one was solved again from, "
    "because its average power or period sat off the kind's smooth curve (comma-separated; "
    "'' when it did not)",
    "resolve_gain_w": "how much more power [W] the kept re-solve's objective gives than the "
    "first optimum (0: the first was the better; NaN: not re-solved)",
    "active_bounds": "bounds the optimum sits on, comma-separated: period_min, period_max, "
    "tether_length_min, tether_length_max, ground_clearance, airspeed_min, airspeed_max, "
    "tether_force_limit, speed_limit, torque_limit, p_elec_limit ('' for none)",
    "bound_limited": "an optimum on a bound the system did not mean to bind (period or tether "
    "length range): the optimum is the bound's, not the kite's",
    "period_s": "cycle period",
    "avg_p_elec_w": "average electrical power (negative = generated)",
    "avg_p_mech_w": "average mechanical power (negative = generated)",
    "e_elec_j": "net electrical energy per cycle (negative = generated)",
    "e_mech_j": "net mechanical energy per cycle (negative = generated)",
    "peak_speed_rpm": "largest |motor speed| (drum speed times the gear ratio)",
    "peak_torque_nm": "largest |torque| the drive delivers at its shaft (tether torque at the "
                      "motor plus the drivetrain's acceleration torque)",
    "peak_reel_acceleration_m_s2": "largest |tether acceleration| (reel acceleration)",
    "p_elec_max_w": "largest electrical power (peak drawn from the grid)",
    "p_elec_min_w": "smallest electrical power (peak generated, negative)",
    "tether_length_min_m": "shortest tether length",
    "tether_length_max_m": "longest tether length",
    "altitude_min_m": "lowest altitude above ground",
    "altitude_max_m": "highest altitude above ground",
    "periodicity_error": "largest scaled residual of the periodicity constraints [-]",
    "max_violation": "largest scaled constraint violation [-]",
    "slack_fraction": "fraction of the cycle time with zero tether tension (slack tether) [-]",
    "outside_domain_time_frac": "share of the cycle time outside the drive model's validity "
                                "domain (its measured envelope per quadrant) [-]; NaN when "
                                "the model has no domain",
    "outside_worst_speed_rpm": "drum speed of the cycle point farthest outside the domain",
    "outside_worst_torque_nm": "drum torque of the cycle point farthest outside the domain",
    "outside_worst_distance": "its distance to the domain in (speed / max_speed_rpm, "
                              "torque / max_torque_nm) [-]; 0 when the cycle stays inside",
}
#: the columns every reader of ``summary.parquet`` relies on (``bench aep``, ``bench size``,
#: ``bench report``); the others are read where present
SUMMARY_REQUIRED = ("scenario", "kind", "objective", "drive_limits", "wind_speed_m_s",
                    "success", "status", "avg_p_elec_w", "avg_p_mech_w", "period_s",
                    "peak_speed_rpm", "peak_torque_nm")
#: the metric columns (NaN for a failed scenario)
_METRICS = list(SUMMARY_COLUMNS)[list(SUMMARY_COLUMNS).index("period_s") :]
#: active bounds the constrained scenarios mean to bind
DRIVE_BOUNDS = ("speed_limit", "torque_limit", "envelope_limit", "p_elec_limit")
#: the kite's and the winch's own limits, in force in every kind
KITE_BOUNDS = ("airspeed_min", "airspeed_max", "tether_force_limit", "reel_acceleration_limit")
#: bounds an optimum may sit on as physics: the drive and kite limits and the ground (a
#: safety limit); the period and tether-length ranges are search ranges, and an optimum
#: on one of them is the range's, not the system's
MEANT_BOUNDS = (*DRIVE_BOUNDS, *KITE_BOUNDS, "ground_clearance")
#: keys of the Parquet files' schema metadata recording the system
SYSTEM_META_KEYS = ("drivebench.system_name", "drivebench.system_sha256",
                    "drivebench.system_toml")


#: columns of ``trajectories.parquet`` (:func:`optimize.solve.result.trajectory_frame` with
#: the scenario's name, kind and wind), also of a sweep in which nothing converged
TRAJECTORY_COLUMNS = ("scenario", "kind", "wind_speed_m_s", "time_s", "interval", "weight",
                      *km.STATES.names, *km.CONTROLS.names, *km.ALGEBRAIC.names,
                      *(c for c in OUTPUT_UNITS if c not in ("time_s", "interval", "weight")))


def _trajectory_metrics(traj: pd.DataFrame) -> dict[str, float]:
    def col(name: str) -> np.ndarray:
        return traj[name].to_numpy(dtype=float)

    peaks = cycle_metrics(traj)
    return {
        "peak_speed_rpm": peaks["peak_speed_rpm"],
        "peak_torque_nm": peaks["peak_torque_nm"],
        "peak_reel_acceleration_m_s2": float(np.max(np.abs(col("ddl_m_s2")))),
        "p_elec_max_w": float(np.max(col("p_elec_w"))),
        "p_elec_min_w": float(np.min(col("p_elec_w"))),
        "tether_length_min_m": float(np.min(col("l_m"))),
        "tether_length_max_m": float(np.max(col("l_m"))),
        "altitude_min_m": float(np.min(col("altitude_m"))),
        "altitude_max_m": float(np.max(col("altitude_m"))),
    }


def _excursion_metrics(traj: pd.DataFrame, domain: dict | None,
                       scales: tuple[float, float]) -> dict[str, float]:
    weight = traj["weight"] if domain else 1.0  # quadrature weights: shares of the cycle time
    e = domain_excursion(traj["speed_rpm"], traj["torque_nm"], weight, domain, scales)
    return {"outside_domain_time_frac": e["time_fraction_outside"],
            "outside_worst_speed_rpm": e["worst_speed_rpm"],
            "outside_worst_torque_nm": e["worst_torque_nm"],
            "outside_worst_distance": e["worst_distance"]}


def resolve_fields(o: ScenarioOutcome) -> dict[str, Any]:
    """``resolved_from`` and ``resolve_gain_w`` of a scenario (see :data:`SUMMARY_COLUMNS`)."""
    if not o.resolves:
        return {"resolved_from": "", "resolve_gain_w": math.nan}
    kept = [r for r in o.resolves if r.kept]
    gain = o.resolves[0].before_w - kept[-1].objective_w if kept else 0.0
    return {"resolved_from": ",".join(dict.fromkeys(r.attempt.source for r in o.resolves)),
            "resolve_gain_w": float(gain)}


def resolve_lines(outcomes: Iterable[ScenarioOutcome]) -> list[str]:
    """One line per scenario re-solved from a neighbour: what each re-solve found."""
    lines = []
    for o in outcomes:
        for r in o.resolves:
            found = (f"{r.objective_w:.1f} W" if r.attempt.success
                     else f"failed ({r.attempt.status})")
            verdict = ("a better optimum, kept" if r.kept else
                       "the same optimum" if r.attempt.success
                       and abs(r.objective_w - r.before_w) <= better_margin_w(r.before_w)
                       else "no better optimum, the first kept")
            lines.append(f"{o.name}: off its kind's smooth curve; re-solved from {r.attempt.source}"
                         f": {found} against {r.before_w:.1f} W: {verdict}")
    return lines


def summary_row(o: ScenarioOutcome, domain: dict | None = None,
                scales: tuple[float, float] = (1.0, 1.0)) -> dict[str, Any]:
    """One summary row; metrics are NaN unless the scenario converged.

    ``domain`` (the drive model's validity domain) and ``scales`` (speed [rpm] and
    torque [N m] of distance 1) give the ``outside_*`` columns.
    """
    last = o.attempts[-1] if o.attempts else None
    row: dict[str, Any] = {
        "scenario": o.name,
        "kind": o.kind,
        "objective": o.objective,
        "drive_limits": o.drive_limits,
        "wind_speed_m_s": o.wind_speed_m_s,
        "success": o.success,
        "status": o.status,
        "result_check": o.check,
        "iterations": last.iterations if last else 0,
        "wall_time_s": last.wall_time_s if last else math.nan,
        "attempts": len(o.attempts),
        "total_wall_time_s": o.total_wall_time_s,
        "warm_source": o.warm_source,
        "chain": o.chain,
        **resolve_fields(o),
    }
    row.update(dict.fromkeys(_METRICS, math.nan))
    if o.success:
        r = o.result
        row.update(
            period_s=float(r.period_s),
            avg_p_elec_w=float(r.avg_p_elec_w),
            avg_p_mech_w=float(r.avg_p_mech_w),
            e_elec_j=float(r.avg_p_elec_w) * float(r.period_s),
            e_mech_j=float(r.avg_p_mech_w) * float(r.period_s),
            periodicity_error=float(getattr(r, "periodicity_error", math.nan)),
            max_violation=float(getattr(r, "max_violation", math.nan)),
        )
        row.update(_trajectory_metrics(r.trajectory))
        row.update(_excursion_metrics(r.trajectory, domain, scales))
        active = tuple(getattr(r, "active_bounds", ()))
        row.update(
            active_bounds=",".join(active),
            bound_limited=any(b not in MEANT_BOUNDS for b in active),
            slack_fraction=float(getattr(r, "slack_fraction", math.nan)),
        )
    else:
        row.update(active_bounds="", bound_limited=False)
    return row


def summary_frame(outcomes: Iterable[ScenarioOutcome], domain: dict | None = None,
                  scales: tuple[float, float] = (1.0, 1.0)) -> pd.DataFrame:
    """The summary table: one row per scenario, columns :data:`SUMMARY_COLUMNS`.

    Parameters
    ----------
    outcomes : iterable of ScenarioOutcome
    domain : dict or None
        The drive model's validity domain (``PowerModel.domain``).
    scales : (float, float)
        Speed [rpm] and torque [N m] of distance 1 for ``outside_worst_distance``.
    """
    frame = pd.DataFrame([summary_row(o, domain, scales) for o in outcomes],
                         columns=list(SUMMARY_COLUMNS))
    return frame.astype(
        {
            "success": bool,
            "drive_limits": bool,
            "bound_limited": bool,
            "active_bounds": str,
            "iterations": "int64",
            "attempts": "int64",
            "chain": "int64",
            "resolved_from": str,
            "result_check": str,
            "resolve_gain_w": float,
        }
    )


def trajectories_frame(outcomes: Iterable[ScenarioOutcome]) -> pd.DataFrame:
    """Every collocation point of every converged scenario, with ``scenario``, ``kind``, wind."""
    parts = []
    for o in outcomes:
        if o.success:
            traj = o.result.trajectory.reset_index(drop=True)
            head = pd.DataFrame(
                {"scenario": o.name, "kind": o.kind, "wind_speed_m_s": o.wind_speed_m_s},
                index=traj.index,
            )
            parts.append(pd.concat([head, traj], axis=1))
    if not parts:  # no converged scenario: no row, every column (a failed sweep is data)
        types = {"scenario": str, "kind": str, "interval": "int64"}
        return pd.DataFrame({c: pd.Series(dtype=types.get(c, float)) for c in TRAJECTORY_COLUMNS})
    return pd.concat(parts, ignore_index=True)


def system_metadata(system: dict | None) -> dict[str, str]:
    """Parquet schema metadata recording the system (``System.record()``) under
    :data:`SYSTEM_META_KEYS`: name, hash and the system file's text."""
    if system is None:
        return {}
    return {key: str(system[field]) for key, field in
            zip(SYSTEM_META_KEYS, ("name", "sha256", "text"), strict=True)}


# ------------------------------------------------------------------ reading back
def field_units(path: Path) -> dict[str, str]:
    """Column -> unit recorded in a Parquet file's field metadata."""
    schema = pq.read_schema(path)
    return {f.name: (f.metadata or {}).get(b"unit", b"").decode() for f in schema}


def read_summary(path: Path) -> pd.DataFrame:
    """Read ``summary.parquet`` and check its columns.

    Raises
    ------
    InputError
        If the file is missing, unreadable or lacks a column of :data:`SUMMARY_REQUIRED`.
    """
    path = Path(path)
    try:
        frame = pd.read_parquet(path)
    except FileNotFoundError as exc:
        raise InputError(
            path, "file not found", expected="bench optimize's summary.parquet"
        ) from exc
    except (OSError, pa.ArrowException) as exc:
        raise InputError(path, f"not a readable Parquet file ({exc})") from exc
    missing = [c for c in SUMMARY_REQUIRED if c not in frame.columns]
    if missing:
        raise InputError(
            path, "missing summary column", column=missing[0], expected=", ".join(SUMMARY_REQUIRED)
        )
    return frame
