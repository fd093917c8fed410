"""A lumped thermal model of the drive's winding, fitted from the bench logs.

Two steps, each a least-squares fit (docs/schemas.md section 3, ``thermal``):

1. **Temperature in the power** (operating points with a winding temperature): the
   electrical power is a polynomial in speed and torque per mode, plus the copper
   loss's drift ``b T^2 (theta - theta_ref)`` and a temperature-only part ``g(theta)``
   (linear hinges, :data:`AUX_KNOTS_C`); the copper coefficient is
   ``b / c2`` [1/K] with ``c2`` the ``T^2`` coefficient at ``theta_ref``. ``g`` is
   taken as an auxiliary load on the same grid connection (a thermostat-controlled
   cabinet fan): electrical power that does not heat the winding.
2. **The winding's heat balance** (time series of the sessions that log it): a
   network of one or two nodes (:mod:`fitting.thermal_network`; one node is
   ``tau_th dtheta/dt = theta_amb + r_th q - theta``) under the heat
   ``q = p_elec - p_mech - g(theta)`` held over bins of :data:`BIN_S` (the ODE's exact
   zero-order-hold solution), one ambient and one start temperature per session,
   the network shared; the measured bin means are compared with the simulated bin
   means (scipy ``least_squares``). How many nodes: held-out prediction and the
   one-standard-error rule (:mod:`fitting.thermal_selection`).

Intervals are 95 % (normal quantile): the points' covariance for step 1; for step 2
the Gauss-Newton covariance inflated by the residuals' lag-1 autocorrelation
(``(1 + rho) / (1 - rho)``: neighbouring bins are not independent). The sensor's own
lag (seconds) is not modelled; it lengthens ``tau_th`` by about that lag.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from fitting.thermal_network import (
    Z95,
    delta_sd,
    fit_chain,
    interval,
    ladder_of,
    mean_time_constant_s,
)
from fitting.thermal_selection import predict, select_nodes
from kernel.thermal_model import ThermalModel

#: reference temperature of the copper coefficient [degC] (IEC 60034-2-1 reference 20 degC
#: for the resistance before correction)
THETA_REF_C = 20.0
#: knots of the temperature-only power g(theta) [degC]
AUX_KNOTS_C = (30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0, 100.0, 120.0)
#: bin of the time series [s] (the winding's time constant is minutes)
BIN_S = 5.0
#: version of the ``thermal`` block of power_model.json (2: networks of 1 or 2 nodes)
THERMAL_VERSION = 2
#: names of the ladder's nodes, from the winding outwards
NODE_NAMES = ("winding", "housing")


def _aux_basis(theta_c: np.ndarray) -> np.ndarray:
    """Columns of g(theta): ``theta - theta_ref`` and the hinges ``max(theta - knot, 0)``."""
    th = np.asarray(theta_c, dtype=float)
    return np.column_stack([th - THETA_REF_C] + [np.maximum(th - k, 0.0) for k in AUX_KNOTS_C])


def _mode_basis(speed_rpm: np.ndarray, torque_nm: np.ndarray) -> list[np.ndarray]:
    """Per-mode speed-torque columns besides T^2: 1, n, n^2, n^3, T, n T."""
    n, t = speed_rpm, torque_nm
    return [np.ones_like(n), n, n**2, n**3, t, n * t]


def copper_fit(points: pd.DataFrame) -> dict:
    """Step 1: the copper coefficient and the auxiliary load from the operating points.

    Parameters
    ----------
    points : pandas.DataFrame
        ``mode``, ``speed_rpm``, ``torque_nm``, ``p_elec_w``, ``t_winding_c`` (finite).

    Returns
    -------
    dict
        ``copper_temp_coeff_per_k`` with ``_ci95``, ``c2_w_per_nm2`` (at theta_ref),
        ``aux`` (knots and coefficients of g [W]), ``rms_w``, ``n_points``.
    """
    n, t = points.speed_rpm.to_numpy(), points.torque_nm.to_numpy()
    th = points.t_winding_c.to_numpy()
    cols = []
    for mode in ("motor", "generator"):
        m = (points["mode"] == mode).to_numpy(float)
        if m.any():
            cols += [m * c for c in _mode_basis(n, t)]
    cols += [t**2, t**2 * (th - THETA_REF_C)]
    i_c2 = len(cols) - 2
    aux = _aux_basis(th)
    x = np.column_stack(cols + [aux])
    keep = np.ptp(x, axis=0) > 0  # hinges above the hottest point are empty
    keep[:i_c2 + 2] = True
    x = x[:, keep]
    y = points.p_elec_w.to_numpy()
    coef, *_ = np.linalg.lstsq(x, y, rcond=None)
    resid = y - x @ coef
    dof = y.size - x.shape[1]
    cov = resid @ resid / dof * np.linalg.pinv(x.T @ x)
    c2, b = coef[i_c2], coef[i_c2 + 1]
    k = b / c2
    # delta method on k = b / c2
    grad = np.array([-b / c2**2, 1.0 / c2])
    var_k = grad @ cov[i_c2:i_c2 + 2, i_c2:i_c2 + 2] @ grad
    aux_coef = np.zeros(aux.shape[1])
    aux_coef[keep[i_c2 + 2:]] = coef[i_c2 + 2:]
    return {
        "copper_temp_coeff_per_k": float(k),
        "copper_temp_coeff_per_k_ci95": interval(k, np.sqrt(var_k)),
        "c2_w_per_nm2": float(c2),
        "aux": {"theta_ref_c": THETA_REF_C, "knots_c": list(AUX_KNOTS_C),
                "linear_w_per_k": float(aux_coef[0]),
                "hinge_w_per_k": [float(c) for c in aux_coef[1:]]},
        "rms_w": float(np.sqrt(np.mean(resid**2))),
        "n_points": int(y.size),
    }


def aux_power_w(theta_c, aux: dict) -> np.ndarray:
    """The auxiliary (non-heating) load g(theta) [W] of :func:`copper_fit`'s ``aux``."""
    coef = np.array([aux["linear_w_per_k"], *aux["hinge_w_per_k"]])
    th = np.asarray(theta_c, dtype=float)
    basis = np.column_stack([th - aux["theta_ref_c"]]
                            + [np.maximum(th - k, 0.0) for k in aux["knots_c"]])
    return basis @ coef


def binned_series(samples: pd.DataFrame, aux: dict, bin_s: float = BIN_S) -> dict:
    """A session's heat input and measured winding temperature on bins of ``bin_s``.

    Returns
    -------
    dict
        ``heat_w`` (losses less the auxiliary load, gaps interpolated) and
        ``theta_c`` (bin means, NaN where the sensor gave none), per bin.
    """
    t = samples.time_s.to_numpy()
    k = ((t - t[0]) // bin_s).astype(np.int64)
    nb = int(k.max()) + 1
    th = samples.t_winding_c.to_numpy()
    heat = (samples.p_elec_w - samples.p_mech_w).to_numpy() - aux_power_w(th, aux)

    def means(x):
        ok = np.isfinite(x)
        cnt = np.bincount(k[ok], minlength=nb)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.bincount(k[ok], x[ok], minlength=nb) / cnt

    heat_b = pd.Series(means(heat)).interpolate(limit_direction="both").to_numpy()
    return {"heat_w": heat_b, "theta_c": means(th), "bin_s": bin_s}


def _resolved(fit: dict) -> bool:
    """Every mode's resistance and time constant has a 95 % interval above zero."""
    sd = np.sqrt(np.maximum(np.diag(fit["cov"]), 0.0))
    return bool(np.all(fit["modes"].ravel() - Z95 * sd > 0))


def _network_fields(fit: dict) -> dict:
    """The block's network keys: totals, modes and ladder with their 95 % intervals."""
    x, cov = fit["modes"].ravel(), fit["cov"]
    r_th = float(fit["modes"][:, 0].sum())
    tau = mean_time_constant_s(fit["modes"])
    sd_r, sd_tau, sd_c = delta_sd(
        lambda v: [v[0::2].sum(), mean_time_constant_s(v.reshape(-1, 2)),
                   mean_time_constant_s(v.reshape(-1, 2)) / v[0::2].sum()], x, cov)
    ladder = ladder_of(fit["modes"])
    sd_ladder = delta_sd(lambda v: ladder_of(v.reshape(-1, 2)).ravel(), x, cov)
    sd_modes = np.sqrt(np.maximum(np.diag(cov), 0.0))
    return {
        "r_th_k_per_w": r_th, "r_th_k_per_w_ci95": interval(r_th, sd_r),
        "tau_th_s": tau, "tau_th_s_ci95": interval(tau, sd_tau),
        "c_th_j_per_k": tau / r_th, "c_th_j_per_k_ci95": interval(tau / r_th, sd_c),
        "modes": [{"r_k_per_w": float(r), "r_k_per_w_ci95": interval(r, sd_modes[2 * i]),
                   "tau_s": float(t), "tau_s_ci95": interval(t, sd_modes[2 * i + 1])}
                  for i, (r, t) in enumerate(fit["modes"])],
        "ladder": [{"node": NODE_NAMES[i] if i < len(NODE_NAMES) else f"node_{i + 1}",
                    "c_j_per_k": float(c), "c_j_per_k_ci95": interval(c, sd_ladder[2 * i]),
                    "r_k_per_w": float(r), "r_k_per_w_ci95": interval(r, sd_ladder[2 * i + 1])}
                   for i, (c, r) in enumerate(ladder)],
    }


def _chosen_fit(series: dict[str, dict]) -> tuple[dict, dict]:
    """The network the selection chooses, fitted on every session, with fewer nodes
    while a mode's interval reaches zero (the data do not resolve it)."""
    selection = select_nodes(series)
    chain = fit_chain(series, selection["chosen_nodes"])
    n = len(chain)
    while n > 1 and not _resolved(chain[n - 1]):
        n -= 1
        selection["note"] = f"{n + 1} nodes chosen, but a mode's interval reaches zero"
    selection["fitted_nodes"] = n
    return chain[n - 1], selection


def fit_thermal(points: pd.DataFrame, samples_of) -> tuple[dict | None, str]:
    """The winding's thermal model from a store's points and samples, and a line saying
    what came out.

    Parameters
    ----------
    points : pandas.DataFrame
        The store's points (``t_winding_c`` NaN where not logged).
    samples_of : callable
        ``samples_of(session_id) -> pandas.DataFrame`` of the store's samples.

    Returns
    -------
    thermal : kernel.thermal_model.ThermalModel or None
        The ``thermal`` block of power_model.json (docs/schemas.md section 3): the
        network the selection chooses (:mod:`fitting.thermal_selection`), with 95 %
        intervals; None without a winding temperature, or when even one node is not
        resolved (a resistance or time constant whose interval reaches zero).
    note : str
        ``"no thermal model: <why>"`` or the fitted parameters in one line.
    """
    if "t_winding_c" not in points or not points.t_winding_c.notna().any():
        return None, "no thermal model: no operating point has a winding temperature"
    pts = points[points.t_winding_c.notna()]
    copper = copper_fit(pts)
    series = {sid: binned_series(samples_of(sid), copper["aux"])
              for sid in sorted(pts.session_id.unique())}
    fit, selection = _chosen_fit(series)
    sessions = ", ".join(sorted(series))
    if not _resolved(fit):
        r, tau = fit["modes"][0]
        return None, ("no thermal model: the fit implies a non-positive thermal resistance "
                      f"or time constant (r_th {r:.3g} K/W, tau_th {tau:.3g} s, an interval "
                      f"reaching zero) from the winding temperatures (t_winding_c) of "
                      f"{sessions}")
    block = ThermalModel.from_dict(_block(fit, copper, pts, selection, sorted(series)))
    note = (f"thermal model ({block.nodes} node{'s' * (block.nodes > 1)}, {sessions}): "
            f"r_th {block.r_th_k_per_w:.4g} K/W, tau_th {block.tau_th_s:.4g} s, "
            f"copper {copper['copper_temp_coeff_per_k']:.4g} /K")
    return block, note


def _block(fit: dict, copper: dict, pts: pd.DataFrame, selection: dict,
           sessions: list[str]) -> dict:
    """The ``thermal`` block of power_model.json of a fitted network."""
    n = fit["modes"].shape[0]
    return {
        "version": THERMAL_VERSION, "nodes": n,
        "model": "theta = ambient_c + sum_i theta_i, modes[i].tau_s dtheta_i/dt = "
                 "modes[i].r_k_per_w * heat_w - theta_i (the ladder: the same network "
                 "node by node); heat_w = p_elec_w - p_mech_w - aux_w(theta); copper T^2 "
                 "term x (1 + copper_temp_coeff_per_k (theta - theta_ref_c))",
        **_network_fields(fit),
        "copper_temp_coeff_per_k": copper["copper_temp_coeff_per_k"],
        "copper_temp_coeff_per_k_ci95": copper["copper_temp_coeff_per_k_ci95"],
        "theta_ref_c": THETA_REF_C,
        "theta_points_c": float(pts.t_winding_c.mean()),
        "ambient_c": float(np.mean(list(fit["ambient_c"].values()))),
        "session_ambient_c": fit["ambient_c"],
        "aux_load": copper["aux"],
        "selection": selection,
        "statistics": {"rms_k": fit["rms_k"], "n_bins": fit["n_bins"], "bin_s": BIN_S,
                       "residual_lag1_corr": fit["residual_lag1_corr"],
                       "power_rms_w": copper["rms_w"], "n_points": copper["n_points"],
                       "solver_status": fit["solver_status"]},
        "sessions": sessions,
    }


def predict_session(thermal: ThermalModel, samples: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """The fitted model's winding temperature over a session, from its first reading.

    The heat is the session's logged losses less the model's auxiliary load; the
    ambient is the model's reference ``ambient_c``.

    Returns
    -------
    predicted_c, measured_c : numpy.ndarray
        Bin means [degC] (measured NaN where the sensor gave none).
    """
    d = binned_series(samples, thermal.aux_load)
    return predict(np.array(thermal.mode_figures()), thermal.ambient_c, d), d["theta_c"]
