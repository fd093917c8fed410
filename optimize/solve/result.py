"""Plain-data results of an OCP solve (picklable: they cross process boundaries)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from optimize.model import kite_model as km
from optimize.model.drive import drum_speed_rpm, drum_torque_nm, mechanical_power_w
from optimize.problem.ocp import Ocp, RawSolve
from optimize.problem.scenario import Scenario

#: units of the trajectory columns that are not states/controls/algebraic variables
OUTPUT_UNITS = {
    "time_s": "s", "interval": "", "weight": "", "speed_rpm": "rpm", "torque_nm": "N m",
    "tension_n": "N", "p_mech_w": "W", "p_elec_w": "W", "altitude_m": "m",
    "airspeed_m_s": "m/s", "alpha_deg": "deg", "beta_deg": "deg", "wind_m_s": "m/s",
    "line_angle_deg": "deg", "c_m2": "m^2", "cdot_m2_s": "m^2/s",
}


@dataclass(frozen=True)
class Solution:
    """Scaled primal and dual vectors of a solve, to warm-start the next one.

    Only valid for an :class:`optimize.problem.ocp.Ocp` with the same ``n_intervals``
    and ``degree`` (checked by :func:`optimize.solve.solve.solve`).
    """

    w: np.ndarray
    lam_x: np.ndarray
    lam_g: np.ndarray
    n_intervals: int
    degree: int


@dataclass(frozen=True)
class OcpResult:
    """Outcome of one scenario.

    Attributes
    ----------
    scenario : Scenario
    status : str
        IPOPT return status of the final solve (e.g. ``"Solve_Succeeded"``).
    success : bool
        IPOPT reported success (converged or acceptable level).
    iterations : int
        IPOPT iterations, all stages/retries included.
    wall_time_s : float
        Wall time of the solver calls [s], all stages/retries included.
    objective : float
        NLP objective at the solution [kW + regularization].
    period_s : float
        Cycle period [s].
    avg_p_elec_w, avg_p_mech_w : float
        Average electrical and mechanical power over the cycle [W]
        (negative = generated).
    periodicity_error : float
        Largest scaled residual of the periodicity constraints [-].
    max_violation : float
        Largest scaled violation of any constraint [-].
    trajectory : pandas.DataFrame
        One row per Radau point (``time_s`` in ``(0, T]``): states, controls,
        algebraic variables and outputs (see ``OUTPUT_UNITS``); ``weight`` are
        the quadrature weights, so ``(weight * p).sum()`` is the cycle average.
    warm : Solution
        Primal/dual vectors to warm-start the next solve.
    stages : tuple of dict
        Per-stage log of a cold start (name, status, iterations, wall_time_s);
        one entry per solver call otherwise.
    start : str
        How the final solve was started: ``"warm start"`` (from a neighbouring
        solution), ``"stored guess"`` (:mod:`optimize.solve.initial_guess`) or
        ``"homotopy"``.
    """

    scenario: Scenario
    status: str
    success: bool
    iterations: int
    wall_time_s: float
    objective: float
    period_s: float
    avg_p_elec_w: float
    avg_p_mech_w: float
    periodicity_error: float
    max_violation: float
    trajectory: pd.DataFrame
    warm: Solution
    stages: tuple[dict, ...]
    start: str = "warm start"


def trajectory_frame(ocp: Ocp, w_scaled: np.ndarray, wind_ref_m_s: float) -> pd.DataFrame:
    """Trajectory at every Radau point of a scaled decision vector."""
    sol = ocp.unpack(w_scaled)
    n, d = ocp.options.n_intervals, ocp.coll.degree
    x = sol["x"][:, 1:]  # states at the Radau points
    z = sol["z"]
    u = np.repeat(sol["u"], d, axis=1)
    interval = np.repeat(np.arange(n), d)
    h = sol["period_s"] / n
    tau = np.tile(ocp.coll.tau[1:], n)
    frame = {"time_s": h * (interval + tau), "interval": interval,
             "weight": np.tile(ocp.coll.quad, n) / n}
    for names, arr in ((km.STATE_NAMES, x), (km.CONTROL_NAMES, u), (km.ALGEBRAIC_NAMES, z)):
        for i, name in enumerate(names):
            frame[name] = arr[i]
    outputs = ocp.dae.outputs.map(x.shape[1])(x, u, z, wind_ref_m_s)
    names = ocp.dae.outputs.name_out()
    out = {name: np.asarray(val).ravel() for name, val in zip(names, outputs, strict=True)}
    r_w = ocp.dae.kite.r_winch_m
    dl = x[km.IDX["dl_m_s"]]
    tension = x[km.IDX["l_m"]] * z[6]
    frame["speed_rpm"] = drum_speed_rpm(dl, r_w)
    frame["torque_nm"] = drum_torque_nm(tension, r_w)
    frame["tension_n"] = tension
    frame["p_mech_w"] = mechanical_power_w(tension, dl)
    frame["p_elec_w"] = np.asarray(
        ocp.drive_model.p_elec_w(frame["speed_rpm"], frame["torque_nm"])
    )
    frame["altitude_m"] = out["altitude_m"]
    frame["airspeed_m_s"] = out["airspeed_m_s"]
    frame["alpha_deg"] = np.degrees(out["alpha_rad"])
    frame["beta_deg"] = np.degrees(out["beta_rad"])
    frame["wind_m_s"] = out["wind_m_s"]
    frame["line_angle_deg"] = np.degrees(np.arccos(np.clip(out["cos_line_angle"], -1, 1)))
    frame["c_m2"] = out["c_m2"]
    frame["cdot_m2_s"] = out["cdot_m2_s"]
    return pd.DataFrame(frame)


def make_result(
    ocp: Ocp,
    scenario: Scenario,
    raw: RawSolve,
    p: np.ndarray,
    bounds: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
    stages: list[dict],
    start: str = "warm start",
) -> OcpResult:
    """Assemble an :class:`OcpResult` from the final solver call and the stage log."""
    traj = trajectory_frame(ocp, raw.w, scenario.wind_speed_m_s)
    g = ocp.constraint_values(raw.w, p)
    lbg, ubg = bounds[2], bounds[3]
    viol_g = np.maximum(np.maximum(lbg - g, g - ubg), 0.0)
    viol_x = np.maximum(np.maximum(bounds[0] - raw.w, raw.w - bounds[1]), 0.0)
    per = float(np.max(np.abs(g[ocp.layout.g_periodic])))
    return OcpResult(
        scenario=scenario,
        status=raw.status,
        success=raw.success,
        iterations=int(sum(s["iterations"] for s in stages)),
        wall_time_s=float(sum(s["wall_time_s"] for s in stages)),
        objective=raw.objective,
        period_s=float(ocp.unpack(raw.w)["period_s"]),
        avg_p_elec_w=float((traj["weight"] * traj["p_elec_w"]).sum()),
        avg_p_mech_w=float((traj["weight"] * traj["p_mech_w"]).sum()),
        periodicity_error=per,
        max_violation=float(max(viol_g.max(initial=0.0), viol_x.max(initial=0.0))),
        trajectory=traj,
        warm=Solution(
            w=raw.w, lam_x=raw.lam_x, lam_g=raw.lam_g,
            n_intervals=ocp.options.n_intervals, degree=ocp.coll.degree,
        ),
        stages=tuple(stages),
        start=start,
    )
