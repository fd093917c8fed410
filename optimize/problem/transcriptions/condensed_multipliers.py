"""Multipliers across the condensed and the full transcription.

A warm start hands the solver the full layout's multipliers, and a solve hands back the
full layout's (:mod:`optimize.problem.transcriptions.condensed_nlp`: the rest of the code
reads only that layout). The rows both NLPs have and the bounds of the variables both
have keep their
multipliers; the bounds of the variables the condensed NLP eliminates are its rows, so
their multipliers move between ``lam_x`` and ``lam_g``. The multipliers of the rows only
one NLP has (the condensed gap rows; the full collocation, algebraic and period-tie
rows) follow from the stationarity of that NLP's Lagrangian,
``grad f + J' lam_g + lam_x = 0``, restricted to the variables those rows pin: one square
sparse solve. At a KKT point of one NLP this gives the other's KKT multipliers exactly.
"""

from __future__ import annotations

import warnings

import casadi as ca
import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from optimize.problem.transcriptions.condensed_nlp import CondensedNlp


def csc(matrix: ca.DM) -> sp.csc_matrix:
    rows, cols = matrix.sparsity().get_triplet()
    return sp.csc_matrix((np.asarray(matrix.nonzeros()), (rows, cols)), shape=matrix.shape)


def _complete(grad: np.ndarray, jac: sp.csc_matrix, lam_x: np.ndarray, lam_g: np.ndarray,
              rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """``lam_g`` with its entries ``rows`` (zero on entry) set so that the Lagrangian's
    gradient vanishes at the variables ``cols`` (as many as ``rows``)."""
    residual = grad + jac.T @ lam_g + lam_x
    block = jac[rows][:, cols].T.tocsc()
    if not (np.all(np.isfinite(residual[cols])) and np.all(np.isfinite(block.data))):
        raise FloatingPointError("the multipliers of the rows only one transcription has "
                                 "did not follow from stationarity: its terms are not finite")
    out = lam_g.copy()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", spla.MatrixRankWarning)  # said below instead
        out[rows] = spla.spsolve(block, -residual[cols])
    if not np.all(np.isfinite(out[rows])):
        raise FloatingPointError("the multipliers of the rows only one transcription has "
                                 "did not follow from stationarity: singular block")
    return out


def to_condensed(c: CondensedNlp, first_order: tuple[ca.Function, ca.Function],
                 w: np.ndarray, p: np.ndarray, lam_x_full: np.ndarray, lam_g_full: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Condensed ``lam_x, lam_g`` at the condensed point ``(w, p)`` from full ones;
    ``first_order``: ``(w, p) -> (f, grad f)`` and ``(w, p) -> (g, jac g)`` of the
    condensed NLP."""
    lam_x = np.zeros(c.n_w)
    own = c.var_src >= 0
    lam_x[own] = lam_x_full[c.var_src[own]]
    lam_x[c.i_period[0]] = lam_x_full[c.full.layout.i_period].sum()
    lam_g = np.zeros(c.n_g)
    lam_g[c.row_g[0]] = lam_g_full[c.row_g[1]]
    lam_g[c.row_w[0]] = lam_x_full[c.row_w[1]]
    grad_fn, jac_fn = first_order
    grad = np.asarray(grad_fn(w, p)[1]).ravel()
    lam_g = _complete(grad, csc(jac_fn(w, p)[1]), lam_x, lam_g, c.gap_rows, c.gap_cols)
    return lam_x, lam_g


def to_full(c: CondensedNlp, first_order: tuple[ca.Function, ca.Function],
            w_full: np.ndarray, p_full: np.ndarray, lam_x: np.ndarray, lam_g: np.ndarray
            ) -> tuple[np.ndarray, np.ndarray]:
    """Full ``lam_x, lam_g`` at the full point ``w_full`` from condensed ones;
    ``first_order``: ``(w, p) -> (f, grad f)`` and ``(w, p) -> (g, jac g)`` of the full
    NLP, as a pair."""
    lay = c.full.layout
    lam_x_full = np.zeros(lay.n_w)
    own = c.var_src >= 0
    lam_x_full[c.var_src[own]] = lam_x[own]
    lam_x_full[c.row_w[1]] = lam_g[c.row_w[0]]
    lam_g_full = np.zeros(lay.n_g)
    lam_g_full[c.row_g[1]] = lam_g[c.row_g[0]]
    rows = np.setdiff1d(np.arange(lay.n_g), c.row_g[1])
    pinned = np.concatenate([lay.i_x[:, 0], lay.i_u.ravel(), lay.i_f.ravel(),
                             lay.i_period[:1]])
    cols = np.setdiff1d(np.arange(lay.n_w), pinned)
    grad_fn, jac_fn = first_order
    grad = np.asarray(grad_fn(w_full, p_full)[1]).ravel()
    jac = csc(jac_fn(w_full, p_full)[1])
    return lam_x_full, _complete(grad, jac, lam_x_full, lam_g_full, rows, cols)
