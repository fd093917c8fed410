"""Derivatives of the transcribed NLP for IPOPT: gradient, Jacobian, Lagrangian Hessian.

Symbolic differentiation of the whole NLP (about 6,100 variables at 40 intervals)
costs seconds each time an OCP is built, more than a warm solve takes. The Radau
transcription is one function repeated at each collocation point
(:class:`optimize.problem.transcriptions.structure.PointBlocks`): its Jacobian and Hessian are
built once, on the point's own variables, evaluated at every point by one CasADi
``map`` and added into the NLP's sparse matrices by constant sparse sums. What is
left (period ties, start, periodicity and average rows, tracking and regularization)
is small and differentiated whole.

The chain rule through the integrands ``s`` of the cycle averages is exact when
``f`` and the other rows are linear in ``s`` with coefficients free of ``w``;
:func:`nlp_derivatives` checks that and differentiates the NLP whole otherwise.
Both give the same functions (``tests/test_derivatives.py``).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Derivatives:
    """Symbolic derivatives of an NLP: inputs ``x, p, lam_f, lam_g``; ``f, grad`` (of
    ``f``), ``g, jac`` (of ``g``) and ``hess``, the upper triangle of the Hessian of
    ``lam_f f + lam_g' g``."""

    x: Any
    p: Any
    lam_f: Any
    lam_g: Any
    f: Any
    grad: Any
    g: Any
    jac: Any
    hess: Any

    def functions(self, solver: str) -> dict[str, ca.Function]:
        """The functions ``solver`` (a key of :data:`FORMATS`) takes, by its option names."""
        if solver not in FORMATS:
            raise ValueError(f"no derivative format for solver {solver!r}; one of "
                             f"{', '.join(FORMATS)}")
        return FORMATS[solver](self)


def ipopt_functions(d: Derivatives) -> dict[str, ca.Function]:
    """IPOPT's: objective gradient, constraint Jacobian, upper triangle of the Hessian."""
    x, p, lf, lg = d.x, d.p, d.lam_f, d.lam_g
    return {
        "grad_f": ca.Function("nlp_grad_f", [x, p], [d.f, d.grad], ["x", "p"],
                              ["f", "grad_f_x"]),
        "jac_g": ca.Function("nlp_jac_g", [x, p], [d.g, d.jac], ["x", "p"],
                             ["g", "jac_g_x"]),
        "hess_lag": ca.Function("nlp_hess_l", [x, p, lf, lg], [d.hess],
                                ["x", "p", "lam_f", "lam_g"], ["hess_gamma_x_x"]),
    }


def fatrop_functions(d: Derivatives) -> dict[str, ca.Function]:
    """fatrop's: the full Hessian and the Lagrangian gradient besides the first order."""
    x, p, lf, lg = d.x, d.p, d.lam_f, d.lam_g
    full = d.hess + ca.triu(d.hess, False).T
    grad_lag = lf * d.grad + ca.mtimes(d.jac.T, lg)
    return {
        "nlp_grad_f": ca.Function("nlp_grad_f", [x, p], [d.grad], ["x", "p"], ["grad_f_x"]),
        "nlp_jac_g": ca.Function("nlp_jac_g", [x, p], [d.g, d.jac], ["x", "p"],
                                 ["g", "jac_g_x"]),
        "nlp_hess_l": ca.Function("nlp_hess_l", [x, p, lf, lg], [grad_lag, full],
                                  ["x", "p", "lam_f", "lam_g"],
                                  ["grad_gamma_x", "hess_gamma_x_x"]),
    }


#: the derivative functions each NLP solver takes (by solver name)
FORMATS = {"ipopt": ipopt_functions, "fatrop": fatrop_functions}


def nlp_derivatives(transcription: Any, solver: str = "ipopt",
                    compile_fn: Callable[[ca.Function], ca.Function] | None = None
                    ) -> dict[str, ca.Function]:
    """The derivative functions of ``transcription.nlp`` in ``solver``'s format.

    Point by point (:attr:`blocks`) when the sums are linear in the integrands; the
    whole NLP at once otherwise. ``compile_fn``, when given, compiles the point's
    Jacobian and Hessian functions (:mod:`optimize.problem.transcriptions.codegen`).
    """
    t0 = time.perf_counter()
    out = _block_derivatives(transcription.nlp, transcription.blocks, compile_fn)
    how = "point by point"
    if out is None:
        out, how = whole_derivatives(transcription.nlp), "whole"
    functions = out.functions(solver)
    log.debug("NLP derivatives (%s) in %.1f s", how, time.perf_counter() - t0)
    return functions


def whole_derivatives(nlp: dict) -> Derivatives:
    """The derivatives by differentiating the whole NLP."""
    x, p, f, g = nlp["x"], nlp["p"], nlp["f"], nlp["g"]
    lam_f = ca.SX.sym("lam_f")
    lam_g = ca.SX.sym("lam_g", g.shape[0])
    hess = ca.triu(ca.hessian(lam_f * f + ca.dot(lam_g, g), x)[0])
    return Derivatives(x, p, lam_f, lam_g, f, ca.gradient(f, x), g, ca.jacobian(g, x), hess)


def sum_into(shape: tuple[int, int], parts: list[tuple[Any, np.ndarray, np.ndarray]]
              ) -> Any:
    """A sparse MX matrix of ``shape`` from nonzero values placed by coordinates.

    Each part is ``(values, rows, cols)``: the vector ``values[k]`` goes to entry
    ``(rows[k], cols[k])``; ``rows[k] < 0`` drops it; values on the same entry add up
    (one constant sparse sum over all parts).
    """
    values = ca.vertcat(*[v for v, _, _ in parts])
    rows = np.concatenate([r for _, r, _ in parts])
    cols = np.concatenate([c for _, _, c in parts])
    src = np.flatnonzero(rows >= 0)
    key = cols[src].astype(np.int64) * shape[0] + rows[src]
    unique, target = np.unique(key, return_inverse=True)
    sp = ca.Sparsity.triplet(shape[0], shape[1], list(map(int, unique % shape[0])),
                             list(map(int, unique // shape[0])))
    sum_to = ca.DM(ca.Sparsity.triplet(unique.size, rows.size, list(map(int, target)),
                                       list(map(int, src))), 1.0)
    return ca.MX(sp, ca.mtimes(sum_to, values))


def entries(matrix: Any) -> tuple[Any, np.ndarray, np.ndarray]:
    """``(nonzeros, rows, cols)`` of a (symbolic) sparse matrix, for :func:`_sum_into`."""
    r, c = (np.asarray(a, dtype=int) for a in matrix.sparsity().get_triplet())
    return matrix.nz[:], r, c


def local_entries(local: ca.Sparsity, index_of: np.ndarray,
                   row_index: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Global ``(row, col)`` of every nonzero of a point matrix at every point, in the
    order of the mapped nonzeros (point after point). ``index_of`` maps a local column
    (and, without ``row_index``, a local row) to the global index per point."""
    r, c = (np.asarray(a, dtype=int) for a in local.get_triplet())
    rows_of = index_of if row_index is None else row_index
    return rows_of[r].T.ravel(), index_of[c].T.ravel()


def _block_derivatives(nlp: dict, b: Any,
                       compile_fn: Callable[[ca.Function], ca.Function] | None = None
                       ) -> Derivatives | None:
    """The derivative functions point by point, or None when the sums are not linear in
    the integrands (then :func:`whole_derivatives` applies)."""
    w, p, g_all = nlp["x"], nlp["p"], nlp["g"]
    n_w, n_g, n_p = w.numel(), g_all.numel(), p.numel()
    n_v, n_pts = b.vars.shape
    n_s = b.s.shape[0]

    # what is not a point row: differentiated whole, with the integrands s as variables
    s = ca.vec(b.s)
    rest = np.setdiff1d(np.arange(n_g), b.rows.ravel())
    g_rest = b.g_s[[int(i) for i in rest]]
    lam_f = ca.SX.sym("lam_f")
    lam_g = ca.SX.sym("lam_g", n_g)
    lag_rest = lam_f * b.f_s + ca.dot(lam_g[[int(i) for i in rest]], g_rest)
    grad_s = ca.gradient(lag_rest, s)
    jac_rest_s = ca.jacobian(g_rest, s)
    grad_f_s = ca.gradient(b.f_s, s)
    ws = ca.vertcat(w, s)
    if (ca.depends_on(grad_s, ws) or ca.depends_on(jac_rest_s, ws)
            or ca.depends_on(grad_f_s, ws)):
        log.debug("NLP sums not linear in the integrands: derivatives of the whole NLP")
        return None

    # the point function's derivatives, built once
    v = ca.SX.sym("v", n_v)
    params = ca.SX.sym("params", len(b.i_params))
    deriv = ca.SX.sym("deriv", b.deriv.shape[0])
    rows_v, integrands_v = b.point.function(v, params, deriv)
    n_r = rows_v.numel()
    lam_r, mu = ca.SX.sym("lam_r", n_r), ca.SX.sym("mu", n_s)
    jac_v = ca.jacobian(ca.vertcat(rows_v, integrands_v), v)
    hess_v = ca.hessian(ca.dot(lam_r, rows_v) + ca.dot(mu, integrands_v), v)[0]
    cse = {"cse": True}
    jac_point = ca.Function("point_jac", [v, params, deriv], [jac_v.nz[:]], cse)
    hess_point = ca.Function("point_hess", [v, params, deriv, lam_r, mu], [hess_v.nz[:]], cse)
    if compile_fn is not None:
        jac_point, hess_point = compile_fn(jac_point), compile_fn(hess_point)
    jac_point, hess_point = jac_point.map(n_pts), hess_point.map(n_pts)

    # where each mapped nonzero goes: point rows into g, integrands into s (as -1 - k)
    s_index = np.arange(n_s * n_pts).reshape(n_pts, n_s).T  # (n_s, n_pts) index into s
    jr, jc = local_entries(jac_v.sparsity(), b.vars, np.vstack([b.rows, -1 - s_index]))
    hr, hc = local_entries(hess_v.sparsity(), b.vars)
    hr = np.where(hr <= hc, hr, -1)  # the upper triangle, as IPOPT takes it

    # the symbolic pieces of the rest, as functions
    rest_fn = ca.Function("rest", [w, p, s], [ca.jacobian(g_rest, w), jac_rest_s,
                                              ca.gradient(b.f_s, w), grad_f_s])
    if ca.jacobian(ca.gradient(lag_rest, w), s).nnz():
        return None
    rest_hess_fn = ca.Function("rest_hess", [w, p, s, lam_f, lam_g],
                               [ca.triu(ca.hessian(lag_rest, w)[0]), grad_s])
    f_fn = ca.Function("f", [w, p], [nlp["f"]])
    g_fn = ca.Function("g", [w, p], [g_all])

    # the assembly, in MX
    x_, p_ = ca.MX.sym("x", n_w), ca.MX.sym("p", n_p)
    lf_, lg_ = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", n_g)
    V = ca.reshape(x_[[int(i) for i in b.vars.T.ravel()]], n_v, n_pts)
    params_, D = p_[b.i_params.tolist()], ca.DM(b.deriv)
    s0 = ca.MX.zeros(n_s * n_pts)  # the rest's derivatives do not depend on s (checked)
    f_, g_ = f_fn(x_, p_), g_fn(x_, p_)
    jac_rest_w, jac_rest_s_, grad_w, grad_s_f = rest_fn(x_, p_, s0)
    jac_nz = ca.vec(jac_point(V, params_, D))
    ds = sum_into((n_s * n_pts, n_w), [(jac_nz, np.where(jr < 0, -1 - jr, -1), jc)])
    rest_jac = [entries(jac_rest_w), entries(ca.mtimes(jac_rest_s_, ds))]
    jac = sum_into((n_g, n_w), [(jac_nz, jr, jc),
                                 *[(nz, rest[r], c) for nz, r, c in rest_jac]])
    grad = grad_w + ca.mtimes(ds.T, grad_s_f)
    hess_rest, mu_ = rest_hess_fn(x_, p_, s0, lf_, lg_)
    MU = ca.reshape(mu_, n_s, n_pts)
    LR = ca.reshape(lg_[[int(i) for i in b.rows.T.ravel()]], n_r, n_pts)
    hess_nz = ca.vec(hess_point(V, params_, D, LR, MU))
    hess = sum_into((n_w, n_w), [(hess_nz, hr, hc), entries(hess_rest)])
    return Derivatives(x_, p_, lf_, lg_, f_, grad, g_, jac, hess)
