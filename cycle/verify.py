"""``bench cycle verify``: the measured energy per cycle against the predictions.

Per kept cycle of a cycle-run session (the store's ``cycles``): the measured electrical
and mechanical energy with their uncertainty, the power model's prediction at the
measured speed and torque (the samples integrated over the cycle, its coefficient
covariance carried through), and the optimizer's prediction; their mean relative error
with its 95 % band, the drift over the cycles, and a verdict in words.

Uncertainty (GUM, limits of error taken as uniform distributions, coverage factor 2):
the power analyzer's limits of error of ``session.toml`` ``[sensors]``
(``power_accuracy_reading`` x |E|, ``power_accuracy_range`` x ``power_range_w`` x T)
and the torque flange's and encoder's (``torque_accuracy_range`` x range x the angle
turned, ``speed_accuracy_reading`` x |E_mech|), common to all cycles; the edges (the
power's change over the cycle times the alignment's resolution, a bin, and the power at
its end times the period's uncertainty); and the repeatability, the scatter of the cycles
about their drift line.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pandas as pd

from bench.cycle_profile import window_integral
from fitting.power_model import PowerModel

#: the paper's figure for the steady map's accuracy on dynamic cycles: within 5 %
CLAIM_RTOL = 0.05
#: coverage factor of the bands (about 95 %)
K = 2.0
#: a round trip's result against :data:`CLAIM_RTOL` (:func:`round_trip_result`)
RESULTS = ("PASS", "FAIL", "INCONCLUSIVE")
_SQRT3 = math.sqrt(3.0)


@dataclasses.dataclass(frozen=True)
class Accuracy:
    """Limits of error a session states (``session.toml`` ``[sensors]``); 0 when not
    stated.

    Parameters
    ----------
    power_reading, power_range : float
        Analyzer: shares of the reading and of ``power_range_w`` [-].
    power_range_w : float
        The analyzer's power range [W].
    torque_range : float
        Torque flange: share of its range [-].
    torque_range_nm : float
        Its range at the drum [N m].
    speed_reading : float
        Encoder: share of the reading [-].
    """

    power_reading: float = 0.0
    power_range: float = 0.0
    power_range_w: float = 0.0
    torque_range: float = 0.0
    torque_range_nm: float = 0.0
    speed_reading: float = 0.0

    @classmethod
    def of_session(cls, metadata: dict) -> tuple[Accuracy, list[str]]:
        """The limits a stored session's ``session.toml`` states, and the keys it lacks."""
        sensors = metadata.get("sensors") or {}
        gear = float(metadata.get("gear_ratio", 1.0)) if metadata.get(
            "measured_side") == "motor" else 1.0
        keys = ("power_accuracy_reading", "power_accuracy_range", "torque_accuracy_range",
                "speed_accuracy_reading")
        missing = [k for k in keys if not isinstance(sensors.get(k), int | float)]
        v = {k: float(sensors.get(k, 0.0)) if k not in missing else 0.0 for k in keys}
        return cls(v["power_accuracy_reading"], v["power_accuracy_range"],
                   float(sensors.get("power_range_w", 0.0)), v["torque_accuracy_range"],
                   float(sensors.get("torque_range_nm", 0.0)) * gear,
                   v["speed_accuracy_reading"]), missing


def round_trip_result(error: float, band: float, tolerance: float = CLAIM_RTOL) -> str:
    """The round trip's result: ``"PASS"`` when a prediction's relative error with its 95 %
    band lies within ``+-tolerance``, ``"FAIL"`` when it lies outside it with its band,
    ``"INCONCLUSIVE"`` when the band reaches across the tolerance (more cycles or better
    instruments decide it)."""
    if abs(error) + band <= tolerance:
        return RESULTS[0]
    return RESULTS[1] if abs(error) - band > tolerance else RESULTS[2]


def generated_words(energy_j: float) -> tuple[str, float]:
    """The one sign convention of a round trip's words: the energy per cycle as what the
    cycle does with it, ``("generated", |E|)`` for a cycle that delivers to the grid
    (``E < 0``, docs/schemas.md Conventions), ``("drawn", E)`` for one that draws."""
    return ("generated", -energy_j) if energy_j < 0 else ("drawn", energy_j)


def energy_drift(energy: np.ndarray, index: np.ndarray) -> tuple[float, float, float]:
    """Slope [J per cycle], its standard error and the residual std [J] of a straight
    line through the cycles' energies (NaN, NaN, 0 for fewer than three cycles)."""
    if energy.size < 3:
        return float("nan"), float("nan"), 0.0
    (slope, icpt), cov = np.polyfit(index, energy, 1, cov=True)
    resid = energy - (slope * index + icpt)
    return float(slope), float(math.sqrt(max(cov[0, 0], 0.0))), float(
        math.sqrt((resid**2).sum() / (energy.size - 2)))


def measured_energy(cycles: pd.DataFrame, acc: Accuracy, bin_s: float,
                    u_period_s: float) -> pd.DataFrame:
    """Per cycle: measured energies with their standard uncertainties [J].

    ``bin_s`` [s] is the alignment's resolution (the edges: the power's change over the
    cycle times it); ``u_period_s`` [s] the standard uncertainty of the period the cycles
    were cut with (the power at the cycle's end times it).

    Columns: ``cycle_id``, ``e_elec_j``, ``u_elec_j`` (total), ``u_elec_systematic_j``
    (analyzer limits, common to all cycles), ``e_mech_j``, ``u_mech_j``,
    ``u_mech_systematic_j``.
    """
    e, t = cycles["e_elec_j"].to_numpy(float), cycles["period_s"].to_numpy(float)
    idx = cycles["cycle_id"].to_numpy(float)
    sys_e = np.hypot(acc.power_reading * e, acc.power_range * acc.power_range_w * t) / _SQRT3
    edge = np.hypot(bin_s * np.abs(cycles["p_elec_end_w"] - cycles["p_elec_start_w"]) / _SQRT3,
                    u_period_s * np.abs(cycles["p_elec_end_w"])).to_numpy()
    rep_e = energy_drift(e, idx)[2]
    m = cycles["e_mech_j"].to_numpy(float)
    sys_m = np.hypot(acc.speed_reading * m,
                     acc.torque_range * acc.torque_range_nm * cycles["angle_rad"]) / _SQRT3
    rep_m = energy_drift(m, idx)[2]
    return pd.DataFrame({
        "cycle_id": cycles["cycle_id"].astype(int), "e_elec_j": e,
        "u_elec_j": np.sqrt(sys_e**2 + edge**2 + rep_e**2), "u_elec_systematic_j": sys_e,
        "u_elec_random_j": np.hypot(edge, rep_e), "e_mech_j": m,
        "u_mech_j": np.sqrt(sys_m**2 + rep_m**2), "u_mech_systematic_j": np.asarray(sys_m),
        "u_mech_random_j": np.full(m.size, rep_m)})


def model_energy(cycles: pd.DataFrame, samples: pd.DataFrame,
                 model: PowerModel) -> tuple[np.ndarray, np.ndarray]:
    """The power model's electrical energy per cycle at the measured speed and torque
    [J], and its standard uncertainty from the coefficient covariance [J] (0 without
    one)."""
    t = samples["time_s"].to_numpy(float)
    speed, torque = samples["speed_rpm"].to_numpy(float), samples["torque_nm"].to_numpy(float)
    ok = np.isfinite(speed) & np.isfinite(torque)
    t, speed, torque = t[ok], speed[ok], torque[ok]
    basis = model.basis(speed, torque)
    pred, unc = [], []
    for r in cycles.itertuples(index=False):
        g = np.array([window_integral(t, b, r.t_start_s, r.t_end_s) for b in basis])
        pred.append(float(model.of_basis(g)))
        unc.append(model.sigma_of_basis(g))
    return np.array(pred), np.array(unc)
