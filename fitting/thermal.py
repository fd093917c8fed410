"""A lumped first-order thermal model of the drive's winding, fitted from the bench logs.

Two steps, each a least-squares fit (docs/schemas.md section 3, ``thermal``):

1. **Temperature in the power** (operating points with a winding temperature): the
   electrical power is a polynomial in speed and torque per mode, plus the copper
   loss's drift ``b T^2 (theta - theta_ref)`` and a temperature-only part ``g(theta)``
   (linear hinges, :data:`AUX_KNOTS_C`); the copper coefficient is
   ``b / c2`` [1/K] with ``c2`` the ``T^2`` coefficient at ``theta_ref``. ``g`` is
   taken as an auxiliary load on the same grid connection (a thermostat-controlled
   cabinet fan): electrical power that does not heat the winding.
2. **The winding's heat balance** (time series of the sessions that log it):
   ``tau_th dtheta/dt = theta_amb + r_th q - theta`` with the heat
   ``q = p_elec - p_mech - g(theta)`` held over bins of :data:`BIN_S` (the ODE's exact
   zero-order-hold solution), one ambient and one start temperature per session,
   ``r_th`` and ``tau_th`` shared; the measured bin means are compared with the
   simulated bin means (scipy ``least_squares``).

Intervals are 95 % (normal quantile): the points' covariance for step 1; for step 2
the Gauss-Newton covariance inflated by the residuals' lag-1 autocorrelation
(``(1 + rho) / (1 - rho)``: neighbouring bins are not independent). The sensor's own
lag (seconds) is not modelled; it lengthens ``tau_th`` by about that lag.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.optimize import least_squares
from scipy.signal import lfilter

#: reference temperature of the copper coefficient [degC] (IEC 60034-2-1 reference 20 degC
#: for the resistance before correction)
THETA_REF_C = 20.0
#: knots of the temperature-only power g(theta) [degC]
AUX_KNOTS_C = (30.0, 40.0, 50.0, 60.0, 70.0, 80.0, 90.0, 100.0, 120.0)
#: bin of the time series [s] (the winding's time constant is minutes)
BIN_S = 5.0
#: normal quantile of a two-sided 95 % interval
Z95 = 1.959963984540054
#: version of the ``thermal`` block of power_model.json
THERMAL_VERSION = 1


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
        "copper_temp_coeff_per_k_ci95": _interval(k, np.sqrt(var_k)),
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


def simulate_bins(heat_w, theta0_c: float, ambient_c: float, r_th_k_per_w: float,
                  tau_th_s: float, bin_s: float = BIN_S) -> np.ndarray:
    """Winding temperature averaged over each bin [degC] (exact first-order solution,
    heat held over each bin), starting at ``theta0_c`` at the first bin's start."""
    q = np.asarray(heat_w, dtype=float)
    a = np.exp(-bin_s / tau_th_s)
    steady = ambient_c + r_th_k_per_w * q
    # theta at the bin starts: theta[k+1] = a theta[k] + (1 - a) steady[k]
    ends, _ = lfilter([1.0 - a], [1.0, -a], steady, zi=[a * theta0_c])
    starts = np.concatenate([[theta0_c], ends[:-1]])
    # mean over a bin of steady + (start - steady) exp(-s / tau)
    return steady + (starts - steady) * tau_th_s / bin_s * (1.0 - a)


def _interval(value: float, sd: float) -> list[float]:
    return [float(value - Z95 * sd), float(value + Z95 * sd)]


def fit_first_order(series: dict[str, dict]) -> dict:
    """Step 2: ``r_th``, ``tau_th`` (shared) and each session's ambient and start temperature.

    Parameters
    ----------
    series : dict
        session id -> :func:`binned_series` output.

    Returns
    -------
    dict
        ``r_th_k_per_w``, ``tau_th_s``, ``c_th_j_per_k`` and each ``*_ci95``,
        ``ambient_c`` per session, ``rms_k``, ``n_bins``, ``residual_lag1_corr``.
    """
    sids = list(series)
    s = len(sids)
    bin_s = next(iter(series.values()))["bin_s"]

    def residuals(p):
        r_th, tau = p[0], p[1]
        out = []
        for i, sid in enumerate(sids):
            d = series[sid]
            sim = simulate_bins(d["heat_w"], p[2 + s + i], p[2 + i], r_th, tau, bin_s)
            out.append((sim - d["theta_c"])[np.isfinite(d["theta_c"])])
        return np.concatenate(out)

    first = [float(d["theta_c"][np.isfinite(d["theta_c"])][0]) for d in series.values()]
    x0 = np.r_[0.05, 600.0, first, first]
    lo = np.r_[1e-6, bin_s, [-50.0] * s, [-50.0] * s]
    hi = np.r_[10.0, 1e6, [250.0] * s, [250.0] * s]
    sol = least_squares(residuals, x0, bounds=(lo, hi), x_scale=np.r_[0.01, 100.0,
                                                                        [1.0] * (2 * s)])
    r = sol.fun
    rho = float(np.corrcoef(r[:-1], r[1:])[0, 1])
    inflate = (1.0 + max(rho, 0.0)) / (1.0 - min(max(rho, 0.0), 0.99))
    cov = r @ r / (r.size - sol.x.size) * np.linalg.pinv(sol.jac.T @ sol.jac) * inflate
    r_th, tau = float(sol.x[0]), float(sol.x[1])
    c_th = tau / r_th
    # delta method on C = tau / R
    grad = np.array([-tau / r_th**2, 1.0 / r_th])
    sd_c = float(np.sqrt(grad @ cov[:2, :2] @ grad))
    return {
        "r_th_k_per_w": r_th, "r_th_k_per_w_ci95": _interval(r_th, np.sqrt(cov[0, 0])),
        "tau_th_s": tau, "tau_th_s_ci95": _interval(tau, np.sqrt(cov[1, 1])),
        "c_th_j_per_k": c_th, "c_th_j_per_k_ci95": _interval(c_th, sd_c),
        "ambient_c": {sid: float(sol.x[2 + i]) for i, sid in enumerate(sids)},
        "rms_k": float(np.sqrt(np.mean(r**2))), "n_bins": int(r.size),
        "residual_lag1_corr": rho, "solver_status": sol.message,
    }


def fit_thermal(points: pd.DataFrame, samples_of) -> tuple[dict | None, str]:
    """Both steps on a store's operating points and samples, and a line saying what came out.

    Parameters
    ----------
    points : pandas.DataFrame
        The store's points (``t_winding_c`` NaN where not logged).
    samples_of : callable
        ``samples_of(session_id) -> pandas.DataFrame`` of the store's samples.

    Returns
    -------
    thermal : dict or None
        The ``thermal`` block of power_model.json (docs/schemas.md section 3): the
        parameters with their 95 % intervals; None without a winding temperature, or
        when the fit implies a non-physical model (a resistance or time constant
        whose interval reaches zero).
    note : str
        ``"no thermal model: <why>"`` or the fitted parameters in one line.
    """
    if "t_winding_c" not in points or not points.t_winding_c.notna().any():
        return None, "no thermal model: no operating point has a winding temperature"
    pts = points[points.t_winding_c.notna()]
    copper = copper_fit(pts)
    series = {sid: binned_series(samples_of(sid), copper["aux"])
              for sid in sorted(pts.session_id.unique())}
    first = fit_first_order(series)
    if not first["r_th_k_per_w_ci95"][0] > 0 or not first["tau_th_s_ci95"][0] > 0:
        return None, ("no thermal model: the fit implies a non-positive thermal resistance "
                      f"or time constant (r_th {first['r_th_k_per_w']:.3g} K/W, tau_th "
                      f"{first['tau_th_s']:.3g} s, an interval reaching zero) from the "
                      f"winding temperatures (t_winding_c) of {', '.join(sorted(series))}")
    ambients = list(first["ambient_c"].values())
    note = (f"thermal model (1 node, {', '.join(sorted(series))}): r_th "
            f"{first['r_th_k_per_w']:.4g} K/W, tau_th {first['tau_th_s']:.4g} s, "
            f"copper {copper['copper_temp_coeff_per_k']:.4g} /K")
    return {
        "version": THERMAL_VERSION, "nodes": 1,
        "model": "tau_th_s dtheta/dt = ambient_c + r_th_k_per_w * heat_w - theta; "
                 "heat_w = p_elec_w - p_mech_w - aux_w(theta); copper T^2 term x "
                 "(1 + copper_temp_coeff_per_k (theta - theta_ref_c))",
        **{k: first[k] for k in ("r_th_k_per_w", "r_th_k_per_w_ci95", "tau_th_s",
                                 "tau_th_s_ci95", "c_th_j_per_k", "c_th_j_per_k_ci95")},
        "copper_temp_coeff_per_k": copper["copper_temp_coeff_per_k"],
        "copper_temp_coeff_per_k_ci95": copper["copper_temp_coeff_per_k_ci95"],
        "theta_ref_c": THETA_REF_C,
        "theta_points_c": float(pts.t_winding_c.mean()),
        "ambient_c": float(np.mean(ambients)),
        "session_ambient_c": first["ambient_c"],
        "aux_load": copper["aux"],
        "statistics": {"rms_k": first["rms_k"], "n_bins": first["n_bins"], "bin_s": BIN_S,
                       "residual_lag1_corr": first["residual_lag1_corr"],
                       "power_rms_w": copper["rms_w"], "n_points": copper["n_points"],
                       "solver_status": first["solver_status"]},
        "sessions": sorted(series),
    }, note


def predict_session(thermal: dict, samples: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """The fitted model's winding temperature over a session, from its first reading.

    The heat is the session's logged losses less the model's auxiliary load; the
    ambient is the model's reference ``ambient_c``.

    Returns
    -------
    predicted_c, measured_c : numpy.ndarray
        Bin means [degC] (measured NaN where the sensor gave none).
    """
    d = binned_series(samples, thermal["aux_load"])
    measured = d["theta_c"]
    theta0 = float(measured[np.isfinite(measured)][0])
    predicted = simulate_bins(d["heat_w"], theta0, thermal["ambient_c"],
                              thermal["r_th_k_per_w"], thermal["tau_th_s"], d["bin_s"])
    return predicted, measured
