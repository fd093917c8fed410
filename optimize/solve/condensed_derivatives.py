"""Derivatives of the condensed NLP, interval by interval.

Each interval's outputs ``y(q)`` (:class:`optimize.problem.condensed.Interval`) depend on
its stage variables ``q`` through the Radau points' unknowns ``v(q)``, the root of the
collocation equations ``G(v, q) = 0``. By the implicit function theorem
``dv/dq = -G_v^-1 G_q``, so ``dy/dq = y_v dv/dq + y_q``; and for multipliers ``nu`` of the
outputs, with the adjoint ``mu = -G_v^-T y_v' nu``, the Hessian of ``nu' y(v(q), q)`` is
``[dv/dq; I]' H [dv/dq; I]`` with ``H`` the Hessian of ``nu' y + mu' G`` in ``(v, q)``.
These are built once (symbolic pieces in SX, the solves with ``G_v`` in MX), evaluated
for every interval by one CasADi ``map``, and added into the NLP's sparse matrices as
:mod:`optimize.solve.derivatives` does for the Radau points. The NLP is linear in the
outputs with coefficients free of the variables (checked), so nothing else couples them.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable

import casadi as ca
import numpy as np

from optimize.problem.condensed import CondensedNlp, Interval
from optimize.solve.derivatives import Derivatives, _entries, _local_entries, _sum_into

log = logging.getLogger(__name__)

#: the linear solver of the solves with an interval's collocation Jacobian ``G_v``
LINEAR_SOLVER = "qr"


def interval_functions(it: Interval) -> tuple[ca.Function, ca.Function]:
    """``(q, a) -> (y, dy/dq)`` and ``(q, a, nu) -> d2(nu' y)/dq2`` of one interval,
    both dense in ``q``."""
    v, q = ca.SX.sym("v", it.n_v), ca.SX.sym("q", it.n_q)
    a = ca.SX.sym("a", it.n_a)
    g, y = it.residual(v, q, a), it.outputs(v, q, a)
    nu, mu = ca.SX.sym("nu", y.shape[0]), ca.SX.sym("mu", it.n_v)
    # sparse: the collocation Jacobian G_v has 1152 nonzeros of 124^2 for the kite, and
    # a sparse QR of it costs a tenth of a dense one
    pieces = ca.Function("interval_pieces", [v, q, a], [
        ca.jacobian(g, v), ca.jacobian(g, q), ca.jacobian(y, v), ca.jacobian(y, q)],
        {"cse": True})
    hess = ca.hessian(ca.dot(nu, y) + ca.dot(mu, g), ca.vertcat(v, q))[0]
    n_v = it.n_v
    hess_fn = ca.Function("interval_lagrangian_hessian", [v, q, a, nu, mu], [
        hess[:n_v, :n_v], hess[:n_v, n_v:], hess[n_v:, n_v:]], {"cse": True})
    qm, am, num = (ca.MX.sym("q", it.n_q), ca.MX.sym("a", it.n_a),
                   ca.MX.sym("nu", y.shape[0]))
    ym, vm = it.solve(qm, am)
    g_v, g_q, y_v, y_q = pieces(vm, qm, am)
    v_q = -ca.solve(g_v, g_q, LINEAR_SOLVER)
    jac = ca.Function("interval_jacobian", [qm, am],
                      [ym, ca.densify(ca.mtimes(y_v, v_q) + y_q).nz[:]])
    mum = -ca.solve(g_v.T, ca.mtimes(y_v.T, num), LINEAR_SOLVER)
    h_vv, h_vq, h_qq = hess_fn(vm, qm, am, num, mum)
    cross = ca.mtimes(v_q.T, h_vq)
    h = ca.mtimes([v_q.T, h_vv, v_q]) + cross + cross.T + h_qq
    return jac, ca.Function("interval_hessian", [qm, am, num], [ca.densify(h).nz[:]])


def _triplets(matrix: ca.DM) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows, columns and values of the nonzeros of a constant sparse matrix."""
    r, col = (np.asarray(a, dtype=int) for a in matrix.sparsity().get_triplet())
    return r, col, np.asarray(matrix.nonzeros(), dtype=float)


def condensed_derivatives(c: CondensedNlp,
                          compile_fn: Callable[[ca.Function], ca.Function] | None = None
                          ) -> Derivatives:
    """The condensed NLP's gradient, Jacobian and Lagrangian Hessian (upper triangle);
    ``compile_fn``, when given, compiles the interval functions.

    Raises
    ------
    ValueError
        When the NLP is not linear in the intervals' outputs with coefficients free of the
        variables (then the interval-wise chain rule would be wrong).
    """
    t0 = time.perf_counter()
    w, p, s = c.w_s, c.p_s, ca.vec(c.s)
    n_y, n = c.s.shape
    n_w, n_g = c.n_w, c.n_g
    lam_f, lam_g = ca.SX.sym("lam_f"), ca.SX.sym("lam_g", n_g)
    lag = lam_f * c.f_s + ca.dot(lam_g, c.g_s)
    grad_s, jac_s, grad_f_s = (ca.gradient(lag, s), ca.jacobian(c.g_s, s),
                               ca.gradient(c.f_s, s))
    ws = ca.vertcat(w, s)
    if (any(ca.depends_on(e, ws) for e in (grad_s, jac_s, grad_f_s))
            or ca.jacobian(ca.gradient(lag, w), s).nnz()):
        raise ValueError("the condensed transcription needs an objective and rows linear in "
                         "the cycle averages and the homotopy terms")
    if ca.depends_on(jac_s, p):
        raise ValueError("the condensed transcription needs rows whose coefficients of the "
                         "cycle averages are constants")
    rest = ca.Function("rest", [w, p], [ca.jacobian(c.g_s, w), ca.gradient(c.f_s, w),
                                        grad_f_s])
    rest_hess = ca.Function("rest_hess", [w, p, lam_f, lam_g],
                            [ca.triu(ca.hessian(lag, w)[0]), grad_s])
    jac_fn, hess_fn = interval_functions(c.interval)
    if compile_fn is not None:
        jac_fn, hess_fn = compile_fn(jac_fn), compile_fn(hess_fn)
    n_q = c.interval.n_q
    # the interval Jacobians' nonzeros (dense n_y x n_q blocks, interval after interval):
    # output i of interval k, variable j at nonzero k n_y n_q + j n_y + i, column i_q[j, k]
    rows_s, cols_s, coef = _triplets(ca.DM(ca.Function("jac_s", [], [jac_s])()["o0"]))
    k, i = np.divmod(cols_s[:, None], n_y)
    j = np.arange(n_q)[None, :]
    t = (k * n_y * n_q + j * n_y + i).ravel()
    jac_cols = c.i_q[j, k].ravel()
    jac_rows = np.repeat(rows_s, n_q)
    jac_coef = ca.DM(np.repeat(coef, n_q))
    ks, is_ = np.divmod(np.arange(n_y * n), n_y)
    t_grad = (ks[:, None] * n_y * n_q + j * n_y + is_[:, None]).ravel()
    hr, hc = _local_entries(ca.Sparsity.dense(n_q, n_q), c.i_q)
    hr = np.where(hr <= hc, hr, -1)  # the upper triangle, as IPOPT takes it

    x_, p_ = ca.MX.sym("x", n_w), ca.MX.sym("p", p.shape[0])
    lf_, lg_ = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", n_g)
    q_ = ca.reshape(x_[c.i_q.T.ravel().tolist()], n_q, n)
    a_ = ca.reshape(p_[c.i_a.T.ravel().tolist()], c.interval.n_a, n)
    ys, jac_nz = jac_fn.map(n)(q_, a_)
    jac_nz = ca.vec(jac_nz)
    fg = ca.Function("f_g_s", [w, p, s], [c.f_s, c.g_s])
    f_, g_ = fg(x_, p_, ca.vec(ys))
    jac_w, grad_w, grad_s_f = rest(x_, p_)
    jac = _sum_into((n_g, n_w), [_entries(jac_w), (jac_coef * jac_nz[t.tolist()], jac_rows,
                                                    jac_cols)])
    per_variable = ca.vec(ca.repmat(grad_s_f.T, n_q, 1))  # d f / d s, once per variable
    grad = grad_w + _sum_into((n_w, 1), [(jac_nz[t_grad.tolist()] * per_variable,
                                          c.i_q[np.tile(np.arange(n_q), n_y * n),
                                                np.repeat(ks, n_q)],
                                          np.zeros(n_y * n * n_q, dtype=int))])
    hess_rest, nu_ = rest_hess(x_, p_, lf_, lg_)
    hess_nz = hess_fn.map(n)(q_, a_, ca.reshape(nu_, n_y, n))
    hess = _sum_into((n_w, n_w), [(ca.vec(hess_nz), hr, hc), _entries(hess_rest)])
    log.debug("condensed NLP derivatives in %.1f s", time.perf_counter() - t0)
    return Derivatives(x_, p_, lf_, lg_, f_, grad, g_, jac, hess)
