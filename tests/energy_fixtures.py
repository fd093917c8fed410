"""A synthetic ``bench optimize`` folder (docs/schemas.md §5) for the energy tests."""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

from kernel.provenance import Provenance
from optimize.paper_model import paper_model
from optimize.sweep_folder import write_sweep_folder

WINDS = (4.0, 5.5, 7.0, 8.5, 10.0)
KINDS = {"elec-lim": ("electrical", True), "mech-free": ("mechanical", False)}


def model_with_covariance():
    m = paper_model()
    # a covariance with correlations: 1 % of each coefficient, correlation 0.3
    s = 0.01 * np.abs(np.array(m.coefficients_rpm))
    cov = 0.3 * np.outer(s, s) + 0.7 * np.diag(s**2)
    return dataclasses.replace(m, covariance_rpm=tuple(map(tuple, cov)))


def write_optimize_folder(folder, model, failed=(), winds=WINDS):
    """A folder written by the sweep's writer (docs/schemas.md §5) with cycles made up
    per wind speed of ``winds``; the scenarios named in ``failed`` failed."""
    rng = np.random.default_rng(1)
    rows, traj = [], []
    for kind, (objective, limits) in KINDS.items():
        for v in winds:
            name = f"{kind}-{v:.1f}"
            n = 40
            t = np.linspace(0, 1, n, endpoint=False)
            speed = -200.0 * v * np.sin(2 * np.pi * t) - 60 * v + rng.normal(0, 5, n)
            torque = np.abs(8.0 * v * (1 + 0.5 * np.cos(2 * np.pi * t)))
            w = np.full(n, 1.0 / n)
            p_elec = float(np.sum(w * model.p_elec_w(speed, torque)))
            p_mech = float(np.sum(w * speed / 9.549296585513721 * torque))
            ok = name not in failed
            rows.append({"scenario": name, "kind": kind, "objective": objective,
                         "drive_limits": limits, "wind_speed_m_s": v, "success": ok,
                         "status": "Solve_Succeeded" if ok else "Infeasible_Problem_Detected",
                         "avg_p_elec_w": p_elec if ok else np.nan,
                         "avg_p_mech_w": p_mech if ok else np.nan,
                         "period_s": 5.0 if ok else np.nan,
                         "peak_speed_rpm": float(np.max(np.abs(speed))),
                         "peak_torque_nm": float(np.max(torque))})
            if ok:
                traj.append(pd.DataFrame({"scenario": name, "kind": kind, "wind_speed_m_s": v,
                                          "weight": w, "speed_rpm": speed, "torque_nm": torque}))
    write_sweep_folder(
        folder, Provenance.start(["bench", "optimize"]), summary=pd.DataFrame(rows),
        trajectories=pd.concat(traj, ignore_index=True), system=None, carried_model=model,
        manifest={"wind_speeds_m_s": list(winds), "kinds": list(KINDS),
                  "drive_model": {"model_sha256": model.sha256, "name": model.name},
                  "cut_in": []})
    return folder
