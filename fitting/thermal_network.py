"""The winding's lumped thermal network: first-order modes, fitted to logged temperatures.

The winding's temperature rise over the ambient under a heat ``q(t)`` [W] is a sum of
``n`` first-order modes (a Foster network)::

    tau_i dtheta_i/dt = r_i q - theta_i,      theta_winding = ambient + sum_i theta_i

Every RC ladder driven at the winding (a Cauer network: the winding's heat capacity,
a resistance to the next node, e.g. the housing, its capacity, ..., a resistance to
the ambient) has exactly one such representation with positive ``r_i`` and ``tau_i``,
and every such sum is realised by a ladder with positive elements (the RC
driving-point impedances of Foster and Cauer; e.g. Gerstenmaier and Wachutka,
Microelectronics Journal 31, 2000). The fit works in modes, where the response is a
sum of exact first-order solutions; :func:`ladder_of` gives the ladder, which is what
the OCP integrates and what names the winding's and the housing's capacity.

One node is the first-order model ``tau_th dtheta/dt = ambient + r_th q - theta``.
A session starts with its winding's rise over the ambient shared by the modes in
proportion to ``r_i`` (the split of a steady heat; exact for a session that starts
cold or after a long steady run).
"""

from __future__ import annotations

import functools

import numpy as np
from scipy.optimize import least_squares
from scipy.signal import lfilter

#: bounds of a mode's resistance [K/W] and time constant [s] in the fit
R_BOUNDS = (1e-6, 10.0)
TAU_BOUNDS = (1.0, 1e6)
#: bounds of a session's ambient and start temperature [degC]
THETA_BOUNDS = (-50.0, 250.0)
#: function evaluations of one least-squares fit (a network with more modes than the
#: data resolve is flat along the spare mode and would wander for long)
MAX_NFEV = 200
#: normal quantile of a two-sided 95 % interval
Z95 = 1.959963984540054


def first_order_bins(steady: np.ndarray, start: float, tau_s: float,
                     bin_s: float) -> np.ndarray:
    """Bin means of ``tau dy/dt = steady - y`` with ``steady`` held over each bin of
    ``bin_s`` [s] (the exact solution), ``y = start`` at the first bin's start."""
    a = np.exp(-bin_s / tau_s)
    ends, _ = lfilter([1.0 - a], [1.0, -a], steady, zi=[a * start])
    starts = np.concatenate([[start], ends[:-1]])
    return steady + (starts - steady) * tau_s / bin_s * (1.0 - a)


def simulate_modes(heat_w: np.ndarray, theta0_c: float, ambient_c: float,
                   modes: np.ndarray, bin_s: float) -> np.ndarray:
    """Winding temperature [degC] averaged over each bin of a heat [W] held per bin.

    Parameters
    ----------
    heat_w : numpy.ndarray
        Heat per bin [W].
    theta0_c, ambient_c : float
        Winding temperature at the first bin's start and the ambient [degC].
    modes : numpy.ndarray
        ``(n, 2)``: per mode its resistance [K/W] and time constant [s].
    bin_s : float
        Bin length [s].
    """
    q = np.asarray(heat_w, dtype=float)
    modes = np.asarray(modes, dtype=float).reshape(-1, 2)
    share = modes[:, 0] / modes[:, 0].sum()
    rise = sum(first_order_bins(r * q, s * (theta0_c - ambient_c), tau, bin_s)
               for (r, tau), s in zip(modes, share, strict=True))
    return ambient_c + rise


def _residuals(series: list[dict], n: int):
    """Residual function of the parameters ``[r_1, tau_1, ..., ambient_s..., theta0_s...]``."""
    s = len(series)

    def residuals(p: np.ndarray) -> np.ndarray:
        modes = p[:2 * n].reshape(n, 2)
        out = []
        for i, d in enumerate(series):
            sim = simulate_modes(d["heat_w"], p[2 * n + s + i], p[2 * n + i], modes,
                                 d["bin_s"])
            out.append((sim - d["theta_c"])[np.isfinite(d["theta_c"])])
        return np.concatenate(out)
    return residuals


def _start(series: list[dict], n: int, modes0: np.ndarray | None) -> np.ndarray:
    first = [float(d["theta_c"][np.isfinite(d["theta_c"])][0]) for d in series]
    modes = np.array([[0.05, 600.0]]) if modes0 is None else np.asarray(modes0, float)
    return np.r_[modes.ravel(), first, first]


def fit_modes(series: dict[str, dict], n: int, modes0: np.ndarray | None = None) -> dict:
    """Least-squares fit of ``n`` modes (shared) and each session's ambient and start.

    Parameters
    ----------
    series : dict
        session id -> ``{"heat_w", "theta_c", "bin_s"}`` (bin means; theta NaN where
        the sensor gave none), :func:`fitting.thermal.binned_series`.
    n : int
        Number of modes (nodes).
    modes0 : numpy.ndarray, optional
        ``(n, 2)`` start values; default one mode of 0.05 K/W and 600 s (``n`` = 1).

    Returns
    -------
    dict
        ``modes`` ``(n, 2)`` sorted by time constant, ``cov`` their ``(2n, 2n)``
        covariance (Gauss-Newton, inflated by ``(1 + rho) / (1 - rho)`` for the
        residuals' lag-1 correlation ``rho``: neighbouring bins are not independent),
        ``ambient_c`` per session, ``rms_k``, ``n_bins``, ``residual_lag1_corr``,
        ``cost``, ``solver_status``.
    """
    sids, data = list(series), list(series.values())
    s = len(sids)
    x0 = _start(data, n, modes0)
    lo = np.r_[[R_BOUNDS[0], TAU_BOUNDS[0]] * n, [THETA_BOUNDS[0]] * 2 * s]
    hi = np.r_[[R_BOUNDS[1], TAU_BOUNDS[1]] * n, [THETA_BOUNDS[1]] * 2 * s]
    scale = np.r_[[0.01, 100.0] * n, [1.0] * 2 * s]
    sol = least_squares(_residuals(data, n), np.clip(x0, lo, hi), bounds=(lo, hi),
                        x_scale=scale, max_nfev=MAX_NFEV, tr_solver="lsmr")
    r = sol.fun
    rho = float(np.corrcoef(r[:-1], r[1:])[0, 1])
    rho_c = min(max(rho, 0.0), 0.99)
    inflate = (1.0 + rho_c) / (1.0 - rho_c)
    dof = max(r.size - sol.x.size, 1)
    cov = r @ r / dof * np.linalg.pinv(sol.jac.T @ sol.jac) * inflate
    order = np.argsort(sol.x[1:2 * n:2])
    idx = np.ravel([[2 * k, 2 * k + 1] for k in order])
    return {
        "modes": sol.x[:2 * n].reshape(n, 2)[order],
        "cov": cov[np.ix_(idx, idx)],
        "ambient_c": {sid: float(sol.x[2 * n + i]) for i, sid in enumerate(sids)},
        "rms_k": float(np.sqrt(np.mean(r**2))), "n_bins": int(r.size),
        "residual_lag1_corr": rho, "cost": float(sol.cost), "solver_status": sol.message,
    }


def fit_chain(series: dict[str, dict], n: int) -> list[dict]:
    """:func:`fit_modes` with 1, 2, ..., ``n`` modes, each started from the fit with one
    mode fewer (a mode split off both ways, fast and slow; the lower cost is kept)."""
    fits = [fit_modes(series, 1)]
    for k in range(2, n + 1):
        starts = []
        for r, tau in fits[-1]["modes"]:
            rest = [m for m in fits[-1]["modes"].tolist() if m != [r, tau]]
            starts += [rest + [[0.3 * r, tau / 10], [0.7 * r, tau]],
                       rest + [[0.7 * r, tau / 3], [0.3 * r, 3 * tau]]]
        fits.append(min((fit_modes(series, k, np.array(m)) for m in starts),
                        key=lambda f: f["cost"]))
    return fits


def fit_network(series: dict[str, dict], n: int) -> dict:
    """:func:`fit_modes` with ``n`` modes (the last of :func:`fit_chain`)."""
    return fit_chain(series, n)[-1]


def _sub(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a - b`` of polynomial coefficients from ``s^0`` up, the length of the longer."""
    out = np.zeros(max(a.size, b.size))
    out[:a.size] += a
    out[:b.size] -= b
    return out


def ladder_of(modes: np.ndarray) -> np.ndarray:
    """The RC ladder of a Foster network (Cauer's continued fraction).

    Parameters
    ----------
    modes : numpy.ndarray
        ``(n, 2)``: per mode ``r_i`` [K/W] and ``tau_i`` [s].

    Returns
    -------
    numpy.ndarray
        ``(n, 2)``: per node from the winding, its heat capacity [J/K] and the
        resistance [K/W] to the next node (the last: to the ambient).
    """
    modes = np.asarray(modes, dtype=float).reshape(-1, 2)
    factors = [np.array([1.0, tau]) for tau in modes[:, 1]]
    # Z(s) = sum r_i / (1 + s tau_i) = num / den, coefficients from s^0 up
    den = functools.reduce(np.convolve, factors)
    num = sum(r * functools.reduce(np.convolve, factors[:i] + factors[i + 1:], np.ones(1))
              for i, r in enumerate(modes[:, 0]))
    y_num, y_den = den, np.atleast_1d(num)  # the admittance Y = y_num / y_den
    nodes = []
    for _ in range(len(modes)):
        c = y_num[-1] / y_den[-1]  # Y ~ s C at high frequency
        y_num = _sub(y_num, np.convolve([0.0, c], y_den))[:-1]  # the top power cancels
        r = y_den[-1] / y_num[-1]  # the rest's impedance y_den / y_num ~ R
        nodes.append([c, r])
        y_den = _sub(y_den, r * y_num)[:-1]
    return np.array(nodes)


def mean_time_constant_s(modes: np.ndarray) -> float:
    """The step response's mean time constant [s]: ``sum r_i tau_i / sum r_i`` (the
    area between its final value and it, over its final value)."""
    modes = np.asarray(modes, dtype=float).reshape(-1, 2)
    return float(modes[:, 0] @ modes[:, 1] / modes[:, 0].sum())


def interval(value: float, sd: float) -> list[float]:
    """A two-sided 95 % normal interval."""
    return [float(value - Z95 * sd), float(value + Z95 * sd)]


def delta_sd(f, x: np.ndarray, cov: np.ndarray, rel_step: float = 1e-6) -> np.ndarray:
    """Standard deviations of ``f(x)`` (a vector) by the delta method, a central-difference
    Jacobian of relative step ``rel_step``."""
    x = np.asarray(x, dtype=float)
    f0 = np.atleast_1d(f(x))
    jac = np.zeros((f0.size, x.size))
    for k in range(x.size):
        h = rel_step * max(abs(x[k]), 1e-12)
        e = np.zeros_like(x)
        e[k] = h
        jac[:, k] = (np.atleast_1d(f(x + e)) - np.atleast_1d(f(x - e))) / (2 * h)
    return np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", jac, cov, jac), 0.0))
