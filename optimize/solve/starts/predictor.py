"""The tangential predictor: a neighbour's optimum moved along its derivative in the
NLP parameters, as the start of the next solve.

At a converged optimum ``(w*, lam_x*, lam_g*)`` of ``p0``, the derivative of the
optimum along a parameter step ``dp = p1 - p0`` solves one linear system, the KKT
system of IPOPT's barrier problem at the optimum (the sensitivity of sIPOPT,
Pirnay, Lopez-Negrete and Biegler, Math. Prog. Comp. 4 (2012) 307-331, eq. 7)::

    [ H + Sx   J'  ] [ dw     ]     [ (d/dp grad_w L) dp ]
    [ J       -D   ] [ dlam_g ] = - [ (d/dp g) dp        ]

with ``H`` the Hessian of the Lagrangian ``L = f + lam_g' g + lam_x' w``, ``J`` the
constraint Jacobian, ``Sx = |lam_x| / (distance of w to the bound it pushes on)``
(the bound multipliers' barrier terms) and ``D = (distance of g to the bound it pushes
on) / |lam_g|`` for an inequality row (0 for an equality row). A bound that binds has
a large ``Sx`` (its variable stays) and a row far from its bounds a large ``D`` (its
multiplier stays); no threshold decides what is active. Fixed variables stay fixed,
and rows whose multiplier is zero keep it. The bound multipliers follow from the
barrier's complementarity, ``dlam_x = Sx dw``.

The start is ``w* + dw`` clipped into the target's bounds and ``lam* + dlam`` with
each multiplier keeping its sign (a flip to the other bound is set to zero); IPOPT's
warm-start options (:func:`optimize.solve.nlp_solver.solver`) take it from there.

The derivatives are the NLP's own
(:func:`optimize.problem.transcriptions.collocation.full_derivatives`): the Hessian and
the Jacobian at the optimum, and their exact forward derivatives in ``p`` (CasADi's
forward mode, built once per OCP).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import casadi as ca
import numpy as np
import scipy.sparse as sps
import scipy.sparse.linalg as spla

from optimize.problem.ocp import Bounds, Ocp
from optimize.problem.transcriptions.collocation import full_derivatives

log = logging.getLogger(__name__)

#: a row whose distance-to-bound over multiplier exceeds this keeps its multiplier
#: (its barrier term would put 1/D below double precision of the Hessian's scale)
INACTIVE_ROW_D = 1e10


@dataclass(frozen=True)
class Tangent:
    """The derivative of an optimum along a parameter step (scaled NLP units).

    Attributes
    ----------
    dw, dlam_x, dlam_g : numpy.ndarray
        Change of the primal vector, the bound and the row multipliers for the
        whole step ``dp``.
    time_s : float
        Wall time of the evaluation, assembly and factorization [s].
    """

    dw: np.ndarray
    dlam_x: np.ndarray
    dlam_g: np.ndarray
    time_s: float


def _functions(ocp: Ocp) -> dict[str, ca.Function]:
    """The NLP's derivative functions and their forward derivatives in ``p`` (built once,
    cached on the OCP)."""
    key = ("predictor",)
    if key not in ocp.solvers:
        d = full_derivatives(ocp, "ipopt")
        ocp.solvers[key] = {"grad_f": d["grad_f"], "jac_g": d["jac_g"],
                            "hess_lag": d["hess_lag"],
                            "grad_f_fwd": d["grad_f"].forward(1),
                            "jac_g_fwd": d["jac_g"].forward(1)}
    return ocp.solvers[key]


def _sparse(m: ca.DM) -> sps.csc_matrix:
    """A CasADi sparse matrix as a SciPy CSC matrix (the same nonzeros)."""
    sp = m.sparsity()
    return sps.csc_matrix((np.asarray(m.nonzeros()), sp.row(), sp.colind()), shape=m.shape)


def _barrier_ratio(value: np.ndarray, lam: np.ndarray, lower: np.ndarray,
                   upper: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per entry, the distance to the bound its multiplier pushes on (upper for a
    positive ``lam``, lower for a negative one; inf for a zero one) and ``|lam|``."""
    dist = np.where(lam > 0, upper - value, np.where(lam < 0, value - lower, np.inf))
    return np.maximum(dist, 0.0), np.abs(lam)


def tangent(ocp: Ocp, w: np.ndarray, lam_x: np.ndarray, lam_g: np.ndarray, p0: np.ndarray,
            dp: np.ndarray, bounds: Bounds) -> Tangent:
    """The derivative of the optimum ``(w, lam_x, lam_g)`` of ``p0`` along ``dp``.

    Parameters
    ----------
    ocp : Ocp
    w, lam_x, lam_g : numpy.ndarray
        The converged solution (scaled, as IPOPT returns it).
    p0 : numpy.ndarray
        The NLP parameters it solves.
    dp : numpy.ndarray
        The parameter step.
    bounds : tuple
        The scaled ``lbx, ubx, lbg, ubg`` it was solved with.

    Returns
    -------
    Tangent
    """
    t0 = time.perf_counter()
    fn = _functions(ocp)
    lbx, ubx, lbg, ubg = bounds
    n_w = w.size
    f0, grad = fn["grad_f"](w, p0)
    g0, jac = fn["jac_g"](w, p0)
    hess_u = _sparse(fn["hess_lag"](w, p0, 1.0, lam_g))
    _, dgrad = fn["grad_f_fwd"](w, p0, f0, grad, 0.0, dp)
    dg, djac = fn["jac_g_fwd"](w, p0, g0, jac, 0.0, dp)
    J = _sparse(jac)
    g = np.asarray(g0).ravel()
    dgrad_l = np.asarray(dgrad).ravel() + _sparse(djac).T @ lam_g
    dg = np.asarray(dg).ravel()

    H = (hess_u + hess_u.T - sps.diags(hess_u.diagonal())).tocsc()
    dist_x, abs_x = _barrier_ratio(w, lam_x, lbx, ubx)
    dist_g, abs_g = _barrier_ratio(g, lam_g, lbg, ubg)
    with np.errstate(divide="ignore", invalid="ignore"):
        sig_x = np.where(np.isfinite(dist_x), abs_x / np.maximum(dist_x, 1e-12), 0.0)
        d_row = np.where(lbg == ubg, 0.0, dist_g / abs_g)
    free = np.flatnonzero(lbx < ubx)
    rows = np.flatnonzero(d_row < INACTIVE_ROW_D)
    K = sps.bmat([[H[free][:, free] + sps.diags(sig_x[free]), J[rows][:, free].T],
                  [J[rows][:, free], -sps.diags(d_row[rows])]], format="csc")
    rhs = -np.concatenate([dgrad_l[free], dg[rows]])
    sol = spla.splu(K).solve(rhs)
    dw = np.zeros(n_w)
    dw[free] = sol[:free.size]
    dlam_g = np.zeros(lam_g.size)
    dlam_g[rows] = sol[free.size:]
    dlam_x = sig_x * dw
    fixed = np.flatnonzero(lbx == ubx)  # their multiplier closes the stationarity row
    if fixed.size:
        resid = H @ dw + dgrad_l + J.T @ dlam_g
        dlam_x[fixed] = -resid[fixed]
    return Tangent(dw, dlam_x, dlam_g, time.perf_counter() - t0)


def predict(ocp: Ocp, w: np.ndarray, lam_x: np.ndarray, lam_g: np.ndarray, p0: np.ndarray,
            p1: np.ndarray, bounds0: Bounds, bounds1: Bounds, step: float = 1.0,
            margin: float = 1e-2) -> tuple[np.ndarray, np.ndarray, np.ndarray, Tangent]:
    """The start of the solve at ``p1`` predicted from the optimum of ``p0``.

    Parameters
    ----------
    ocp : Ocp
    w, lam_x, lam_g : numpy.ndarray
        The optimum of ``p0`` (scaled).
    p0, p1 : numpy.ndarray
        The NLP parameters it solves and those of the next solve.
    bounds0, bounds1 : tuple
        The scaled ``lbx, ubx, lbg, ubg`` of both solves.
    step : float
        Fraction of the tangent step taken (1: the whole first-order prediction).
    margin : float
        The predicted point stays this far inside a bound (scaled), or a quarter of
        the range when that is narrower; fixed variables take their value.

    Returns
    -------
    tuple
        ``(w, lam_x, lam_g, tangent)``: the start, each multiplier keeping its sign (a
        flip to the other bound is set to zero), and the :class:`Tangent`.
    """
    tg = tangent(ocp, w, lam_x, lam_g, p0, p1 - p0, bounds0)
    lbx, ubx = bounds1[0], bounds1[1]
    room = np.minimum(margin, 0.25 * (ubx - lbx))
    w1 = np.where(lbx == ubx, lbx, np.clip(w + step * tg.dw, lbx + room, ubx - room))
    lx = lam_x + step * tg.dlam_x
    lx = np.where(lx * lam_x < 0, 0.0, lx)
    lg = lam_g + step * tg.dlam_g
    lg = np.where((bounds1[2] != bounds1[3]) & (lg * lam_g < 0), 0.0, lg)
    return w1, lx, lg, tg
