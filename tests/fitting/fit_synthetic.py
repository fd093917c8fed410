"""Synthetic operating points with a known truth, over the paper's bench ranges."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd

#: docs/paper_figures.md §1, paper Table I: P_elec = a0 + a1 w^2 + a2 T^2 + a3 w T (rpm, N m, W).
PAPER_A = (293.5816373499238, 0.0003931623408, 0.0665919381751, 0.1078628659825)


def synthetic_points(
    p_elec_fn,
    *,
    n_motor: int = 520,
    n_generator: int = 520,
    noise_w: float = 40.0,
    seed: int = 1,
) -> pd.DataFrame:
    """Operating points as ``bench ingest`` stores them (docs/schemas.md §2).

    Motor campaign: 50..1500 rpm x 0..78 N m. Generator campaign: -3000..0 rpm,
    torque 0..78 N m with |P_mech| <= 10 kW (paper section III-B). Points sit on
    a jittered grid, as a bench campaign steps through set points.

    Parameters
    ----------
    p_elec_fn : callable
        Truth ``(speed_rpm, torque_nm) -> p_elec_w``.
    noise_w : float
        Standard deviation of Gaussian noise added to P_elec [W].
    """
    rng = np.random.default_rng(seed)
    motor_s = rng.uniform(50, 1500, n_motor)
    motor_t = rng.uniform(0, 78, n_motor)
    gen_s = rng.uniform(-3000, -5, 4 * n_generator)
    gen_t_max = np.minimum(78.0, 10_000.0 / (np.abs(gen_s) * 2 * np.pi / 60))
    gen_t = rng.uniform(0, 1, gen_s.size) * gen_t_max
    gen_s, gen_t = gen_s[:n_generator], gen_t[:n_generator]
    speed = np.concatenate([motor_s, gen_s])
    torque = np.concatenate([motor_t, gen_t])
    p_mech = speed * 2 * np.pi / 60 * torque
    p_elec = p_elec_fn(speed, torque) + rng.normal(0, noise_w, speed.size)
    mode = np.array(["motor"] * n_motor + ["generator"] * n_generator)
    return pd.DataFrame({
        "session_id": np.where(mode == "motor", "motor_01", "generator_01"),
        "point_id": np.concatenate([np.arange(n_motor), np.arange(n_generator)]).astype("int32"),
        "mode": mode,
        "quadrant": np.where(p_mech > 0, "motor", "generator"),
        "source": "timeseries",
        "speed_rpm": speed,
        "torque_nm": torque,
        "p_mech_w": p_mech,
        "p_elec_w": p_elec,
    })


def paper_quadratic(speed_rpm, torque_nm):
    """The paper's eq. 4 with the Table I coefficients."""
    a0, a1, a2, a3 = PAPER_A
    return a0 + a1 * speed_rpm**2 + a2 * torque_nm**2 + a3 * speed_rpm * torque_nm


def write_store(frame: pd.DataFrame, store) -> None:
    """Write points as ``<store>/points/<session_id>.parquet`` with a manifest listing them.

    The layout of a schema_version 1 store (docs/schemas.md section 2), which
    readers still read.
    """
    (store / "points").mkdir(parents=True, exist_ok=True)
    sessions = {}
    for sid, sub in frame.groupby("session_id"):
        sub.to_parquet(store / "points" / f"{sid}.parquet", index=False)
        sessions[str(sid)] = {"n_points": len(sub)}
    manifest = {"schema": "drivebench.store", "schema_version": 1, "sessions": sessions}
    (store / "manifest.json").write_text(json.dumps(manifest), encoding="utf-8")
