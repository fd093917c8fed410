"""The rows of ``bench optimize``'s files built from the sweep's outcomes: one summary
row per scenario (:data:`optimize.sweep_folder.SUMMARY_COLUMNS`) and the trajectories of
the converged ones. The folder's schema, writer and readers are
:mod:`optimize.sweep_folder`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

import pandas as pd

from fitting.domain import domain_excursion
from optimize.cycles import cycle_metrics
from optimize.service.local_optima import better_margin_w
from optimize.service.outcome import Resolve, ScenarioOutcome
from optimize.sweep_folder import SUMMARY_COLUMNS

#: the metric columns (NaN for a failed scenario)
_METRICS = list(SUMMARY_COLUMNS)[list(SUMMARY_COLUMNS).index("period_s") :]
#: the summary's columns of :func:`optimize.cycles.cycle_metrics`
TRAJECTORY_METRICS = ("peak_speed_rpm", "peak_torque_nm", "peak_reel_acceleration_m_s2",
                      "p_elec_max_w", "p_elec_min_w",
                      "tether_length_min_m", "tether_length_max_m", "altitude_min_m",
                      "altitude_max_m")
#: active bounds the constrained scenarios mean to bind
DRIVE_BOUNDS = ("speed_limit", "torque_limit", "envelope_limit", "p_elec_limit",
                "winding_temperature_limit")
#: the kite's and the winch's own limits, in force in every kind
KITE_BOUNDS = ("airspeed_min", "airspeed_max", "alpha_min", "alpha_max", "beta_min",
               "beta_max", "tether_force_limit", "reel_acceleration_limit",
               "reel_jerk_limit", "reel_out_speed_limit", "reel_in_speed_limit",
               "body_rate_limit", "tension_min", "line_angle_limit", "surface_limit")
#: bounds an optimum may sit on as physics: the drive and kite limits and the ground (a
#: safety limit); the period and tether-length ranges are search ranges, and an optimum
#: on one of them is the range's, not the system's
MEANT_BOUNDS = (*DRIVE_BOUNDS, *KITE_BOUNDS, "ground_clearance")


def _trajectory_metrics(traj: pd.DataFrame) -> dict[str, float]:
    figures = cycle_metrics(traj)
    return {name: math.nan if figures[name] is None else figures[name]
            for name in TRAJECTORY_METRICS}


def _excursion_metrics(traj: pd.DataFrame, domain: dict | None,
                       scales: tuple[float, float]) -> dict[str, float]:
    weight = traj["weight"] if domain else 1.0  # quadrature weights: shares of the cycle time
    e = domain_excursion(traj["speed_rpm"], traj["torque_nm"], weight, domain, scales)
    # the drive's loss energy: P_elec - P_mech (>= 0 where the model is a drive's) per point
    loss = (traj["p_elec_w"] - traj["p_mech_w"]).clip(lower=0.0) if domain else 1.0
    lost = domain_excursion(traj["speed_rpm"], traj["torque_nm"], weight * loss, domain,
                            scales)
    return {"outside_domain_time_frac": e["time_fraction_outside"],
            "outside_domain_loss_frac": lost["time_fraction_outside"],
            "outside_worst_speed_rpm": e["worst_speed_rpm"],
            "outside_worst_torque_nm": e["worst_torque_nm"],
            "outside_worst_distance": e["worst_distance"]}


def resolve_fields(o: ScenarioOutcome) -> dict[str, Any]:
    """``resolved_from``, ``periods_scanned`` and ``resolve_gain_w`` of a scenario (see
    :data:`SUMMARY_COLUMNS`)."""
    scanned = sum(r.held_period_s is not None for r in o.resolves)
    if not o.resolves:
        return {"resolved_from": "", "periods_scanned": 0, "resolve_gain_w": math.nan}
    kept = [r for r in o.resolves if r.kept]
    gain = o.resolves[0].before_w - kept[-1].objective_w if kept else 0.0
    return {"resolved_from": ",".join(dict.fromkeys(r.attempt.source for r in o.resolves)),
            "periods_scanned": scanned, "resolve_gain_w": float(gain)}


def resolve_lines(outcomes: Iterable[ScenarioOutcome]) -> list[str]:
    """One line per re-solve of a scenario (from a neighbour, or by the period scan):
    what it found."""
    lines = []
    for o in outcomes:
        for r in o.resolves:
            found = (f"{r.objective_w:.1f} W" if r.attempt.success
                     else f"failed ({r.attempt.status})")
            why = ("period scan; solved" if r.held_period_s is not None
                   else "a neighbour's better optimum carried on; re-solved" if r.carried
                   else "a better optimum found from this one, offered back; re-solved"
                   if r.back
                   else "off its kind's smooth curve; re-solved")
            lines.append(f"{o.name}: {why} from {r.attempt.source} in "
                         f"{r.attempt.iterations} iterations: {found} against "
                         f"{r.before_w:.1f} W: {_verdict(r)}")
    return lines


def _verdict(r: Resolve) -> str:
    """What a re-solve's optimum is to the first one, in words."""
    if r.kept:
        return "a better optimum, kept"
    if not r.attempt.success:
        return "no better optimum, the first kept"
    margin = better_margin_w(r.before_w)
    if abs(r.objective_w - r.before_w) <= margin:
        return "the same optimum"
    if r.objective_w < r.before_w - margin:
        return "a better optimum, another start's best kept"
    return "a poorer optimum, the first kept"


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
        "intermediate_points": last.intermediate_points if last else 0,
        "intermediate_iterations": last.intermediate_iterations if last else 0,
        "wall_time_s": last.wall_time_s if last else math.nan,
        "attempts": len(o.attempts),
        "total_wall_time_s": o.total_wall_time_s,
        "warm_source": o.warm_source,
        "depth": o.depth,
        "chain": o.chain,
        "n_intervals": int(getattr(getattr(o.result, "warm", None), "n_intervals", 0)),
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
        row.update(getattr(r, "figures", {}))
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
    """The summary table: one row per scenario, columns :data:`SUMMARY_COLUMNS`, then the
    figures of a part that table does not name (:meth:`optimize.problem.part.Part.figures`;
    NaN where a scenario failed).

    Parameters
    ----------
    outcomes : iterable of ScenarioOutcome
    domain : dict or None
        The drive model's validity domain (``PowerModel.domain``).
    scales : (float, float)
        Speed [rpm] and torque [N m] of distance 1 for ``outside_worst_distance``.
    """
    rows = [summary_row(o, domain, scales) for o in outcomes]
    extra = [c for c in dict.fromkeys(k for r in rows for k in r) if c not in SUMMARY_COLUMNS]
    frame = pd.DataFrame(rows, columns=[*SUMMARY_COLUMNS, *extra])
    return frame.astype(
        {
            "success": bool,
            "drive_limits": bool,
            "bound_limited": bool,
            "active_bounds": str,
            "iterations": "int64",
            "intermediate_points": "int64",
            "intermediate_iterations": "int64",
            "attempts": "int64",
            "depth": "int64",
            "chain": "int64",
            "n_intervals": "int64",
            "resolved_from": str,
            "periods_scanned": "int64",
            "result_check": str,
            "resolve_gain_w": float,
        }
    )


def trajectories_frame(outcomes: Iterable[ScenarioOutcome],
                       columns: Iterable[str]) -> pd.DataFrame:
    """Every collocation point of every converged scenario, with ``scenario``, ``kind`` and
    the wind speed before the trajectory's ``columns``
    (:func:`optimize.problem.part.trajectory_columns` of the OCP's parts): every one of
    them also when nothing converged (no row; a failed sweep is data)."""
    head_columns = ("scenario", "kind", "wind_speed_m_s")
    parts = []
    for o in outcomes:
        if o.success:
            traj = o.result.trajectory.reset_index(drop=True)
            head = pd.DataFrame(dict(zip(head_columns, (o.name, o.kind, o.wind_speed_m_s),
                                         strict=True)), index=traj.index)
            parts.append(pd.concat([head, traj], axis=1))
    if not parts:
        types = {"scenario": str, "kind": str, "interval": "int64"}
        return pd.DataFrame({c: pd.Series(dtype=types.get(c, float))
                             for c in (*head_columns, *columns)})
    return pd.concat(parts, ignore_index=True)
