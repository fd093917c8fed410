"""Derivatives of the condensed NLP, interval by interval, each interval solved once per point.

Each interval's outputs ``y(q)``
(:class:`optimize.problem.transcriptions.condensed_nlp.Interval`) depend on its stage
variables ``q`` through the Radau points' unknowns ``v(q)``, the root of the
collocation equations ``G(v, q) = 0``. By the implicit function theorem
``dv/dq = -G_v^-1 G_q``, so ``dy/dq = y_v dv/dq + y_q``; and for multipliers ``nu`` of the
outputs, with the adjoint ``mu = -G_v^-T y_v' nu``, the Hessian of ``nu' y(v(q), q)`` is
``[dv/dq; I]' H [dv/dq; I]`` with ``H`` the Hessian of ``nu' y + mu' G`` in ``(v, q)``.

A solver asks for the objective, the rows, the gradient, the Jacobian and the Hessian
in separate calls, most of them at the same point. :class:`IntervalCache` solves the
intervals' collocation (Newton's method) and their sensitivities ``dv/dq`` once per
point and hands them to every call at that point; the calls reach it through CasADi
callbacks, so the NLP's assembly (constant sparse sums, as
:mod:`optimize.problem.transcriptions.derivatives` does for the Radau points) stays in
CasADi. The NLP is
linear in the outputs with coefficients free of the variables (checked), so nothing
else couples the intervals.
"""

from __future__ import annotations

import hashlib
import logging
import time
from collections import OrderedDict
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import casadi as ca
import numpy as np

from optimize.problem.deadline import passed
from optimize.problem.transcriptions.condensed_nlp import CondensedNlp, Interval
from optimize.problem.transcriptions.derivatives import (
    Derivatives,
    entries,
    local_entries,
    sum_into,
)
from optimize.problem.transcriptions.gate import Wrapped

log = logging.getLogger(__name__)

#: the linear solver of the solves with an interval's collocation Jacobian ``G_v``
LINEAR_SOLVER = "qr"
#: points whose interval solutions are kept (the current iterate and the trial points of
#: its line search)
KEEP_POINTS = 4


@dataclass(frozen=True)
class IntervalFunctions:
    """One interval's functions, dense in its stage variables ``q``: ``solve(q, a) ->
    (y, v)``; ``first(v, q, a) -> (dy/dq, dv/dq)``; ``second(v, q, a, dv/dq, nu) ->
    d2(nu' y)/dq2`` (each matrix as its column-major nonzeros)."""

    solve: ca.Function
    first: ca.Function
    second: ca.Function

    def compiled(self, compile_fn: Callable[[ca.Function], ca.Function]) -> IntervalFunctions:
        """The three functions through ``compile_fn``."""
        return IntervalFunctions(*(compile_fn(f) for f in (self.solve, self.first,
                                                           self.second)))


def interval_functions(it: Interval) -> IntervalFunctions:
    """The :class:`IntervalFunctions` of ``it``."""
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
    vm, qm, am = ca.MX.sym("v", it.n_v), ca.MX.sym("q", it.n_q), ca.MX.sym("a", it.n_a)
    num, v_qm = ca.MX.sym("nu", y.shape[0]), ca.MX.sym("v_q", it.n_v * it.n_q)
    g_v, g_q, y_v, y_q = pieces(vm, qm, am)
    v_q = ca.densify(-ca.solve(g_v, g_q, LINEAR_SOLVER))
    first = ca.Function("interval_jacobian", [vm, qm, am],
                        [ca.densify(ca.mtimes(y_v, v_q) + y_q).nz[:], v_q.nz[:]])
    v_q = ca.reshape(v_qm, it.n_v, it.n_q)
    mum = -ca.solve(g_v.T, ca.mtimes(y_v.T, num), LINEAR_SOLVER)
    h_vv, h_vq, h_qq = hess_fn(vm, qm, am, num, mum)
    cross = ca.mtimes(v_q.T, h_vq)
    h = ca.mtimes([v_q.T, h_vv, v_q]) + cross + cross.T + h_qq
    second = ca.Function("interval_hessian", [vm, qm, am, v_qm, num], [ca.densify(h).nz[:]])
    return IntervalFunctions(it.solve, first, second)


class Late(Exception):
    """A point not solved yet, asked for past the thread's deadline."""


class _Buffered:
    """A CasADi function called on NumPy arrays of its inputs' nonzeros, copy-free (a
    conversion between CasADi and NumPy matrices costs more than the rest of a call);
    each call's outputs are new arrays of their nonzeros."""

    def __init__(self, fn: ca.Function) -> None:
        self._buf, self._eval = fn.buffer()
        self._n_out = [fn.nnz_out(i) for i in range(fn.n_out())]
        self._name = fn.name()

    def __call__(self, *args: np.ndarray) -> list[np.ndarray]:
        for i, a in enumerate(args):
            self._buf.set_arg(i, memoryview(a))
        out = [np.empty(n) for n in self._n_out]
        for i, o in enumerate(out):
            self._buf.set_res(i, memoryview(o))
        self._eval()
        if self._buf.ret():
            raise RuntimeError(f"{self._name} failed (return flag {self._buf.ret()})")
        return out


class IntervalCache:
    """The intervals' Newton solutions and sensitivities at the last few points.

    ``outputs``, ``jacobian`` and ``hessian`` take the condensed NLP's ``(w, p)`` and
    give their results as the nonzeros of dense matrices, all NumPy arrays; the Newton
    solves at a point run at the first call there, the sensitivities ``dv/dq`` at the
    first call of ``jacobian`` or ``hessian`` there, and both are kept for the
    :data:`KEEP_POINTS` points last asked for and for the last point whose sensitivities
    were asked for (the solver's iterate, which a line search's trial points must not
    push out). Past the thread's deadline (:mod:`optimize.problem.deadline`) a point not
    solved yet raises :class:`Late`, nothing computed, once the solver's call has an
    iterate (:meth:`begin_call` starts a call); a solved point is still answered: the
    solver returns its iterate and evaluates it once more when its call ends there.
    ``points`` and ``unsolved`` count the points solved and those where an interval's
    Newton solve did not converge (its outputs NaN: an evaluation error).
    """

    def __init__(self, c: CondensedNlp, fns: IntervalFunctions) -> None:
        n = c.n_intervals
        w, p = ca.MX.sym("w", c.n_w), ca.MX.sym("p", c.p_s.shape[0])
        q = ca.reshape(w[c.i_q.T.ravel().tolist()], c.interval.n_q, n)
        a = ca.reshape(p[c.i_a.T.ravel().tolist()], c.interval.n_a, n)
        y, v = fns.solve.map(n)(q, a)
        vs = ca.MX.sym("v", v.shape)
        y_q, v_q = fns.first.map(n)(vs, q, a)
        v_qs, nu = ca.MX.sym("v_q", v_q.shape), ca.MX.sym("nu", y.shape)
        self._solve = _Buffered(ca.Function("intervals_solve", [w, p], [
            ca.densify(y), ca.densify(v)]))
        self._first = _Buffered(ca.Function("intervals_first", [w, p, vs], [
            ca.densify(y_q), ca.densify(v_q)]))
        self._second = _Buffered(ca.Function("intervals_second", [w, p, vs, v_qs, nu], [
            ca.densify(fns.second.map(n)(vs, q, a, v_qs, nu))]))
        self._points: OrderedDict[bytes, dict[str, np.ndarray]] = OrderedDict()
        self._iterate = b""
        self._answering = False
        self.points = self.unsolved = 0

    def _point(self, w: np.ndarray, p: np.ndarray) -> tuple[bytes, dict[str, np.ndarray]]:
        h = hashlib.blake2b(digest_size=16)
        h.update(w)
        h.update(p)
        key = h.digest()
        entry = self._points.get(key)
        if entry is not None:
            self._points.move_to_end(key)
            return key, entry
        if self._iterate and not self._answering and passed():
            raise Late
        y, v = self._solve(w, p)
        entry = {"y": y, "v": v}
        self.points += 1
        self.unsolved += bool(np.isnan(y).any())
        self._points[key] = entry
        if len(self._points) > KEEP_POINTS:
            del self._points[next(k for k in self._points if k != self._iterate)]
        return key, entry

    def begin_call(self) -> None:
        """A solver's call begins: it has no iterate yet."""
        self._iterate = b""

    @contextmanager
    def answering(self) -> Iterator[None]:
        """While open, every point is solved, whatever the time (:class:`Answered`)."""
        before, self._answering = self._answering, True
        try:
            yield
        finally:
            self._answering = before

    def outputs(self, w: np.ndarray, p: np.ndarray) -> np.ndarray:
        """The intervals' outputs ``y`` (one column per interval)."""
        return self._point(w, p)[1]["y"]

    def _sensitivities(self, w: np.ndarray, p: np.ndarray) -> dict[str, np.ndarray]:
        self._iterate, e = self._point(w, p)
        if "y_q" not in e:
            e["y_q"], e["v_q"] = self._first(w, p, e["v"])
        return e

    def jacobian(self, w: np.ndarray, p: np.ndarray) -> np.ndarray:
        """The intervals' ``dy/dq`` (column-major nonzeros, one column per interval)."""
        return self._sensitivities(w, p)["y_q"]

    def hessian(self, w: np.ndarray, p: np.ndarray, nu: np.ndarray) -> np.ndarray:
        """The intervals' ``d2(nu' y)/dq2`` for output multipliers ``nu`` (columns)."""
        e = self._sensitivities(w, p)
        return self._second(w, p, e["v"], e["v_q"], nu)[0]


class _Call(ca.Callback):
    """A Python function of NumPy arrays (the nonzeros of dense matrices) as a CasADi
    function (no derivatives).

    An evaluation the function refuses with :class:`Late` fails with a return flag,
    which ends the solver's call in silence: IPOPT takes it for an evaluation error and
    stops at its own time limit, fatrop returns. An exception would not do: CasADi
    prints one raised in a callback, with its traceback and every input of every
    enclosing function, and NaN outputs make fatrop hang.
    """

    def __init__(self, name: str, fn: Callable[..., np.ndarray],
                 shapes_in: list[tuple[int, int]], shape_out: tuple[int, int]) -> None:
        ca.Callback.__init__(self)
        self._fn, self._in, self._out = fn, shapes_in, shape_out
        self.owner = getattr(fn, "__self__", None)  # the cache of a bound method
        self.construct(name, {})

    def get_n_in(self) -> int:
        return len(self._in)

    def get_n_out(self) -> int:
        return 1

    def get_sparsity_in(self, i: int) -> ca.Sparsity:
        return ca.Sparsity.dense(*self._in[i])

    def get_sparsity_out(self, i: int) -> ca.Sparsity:
        return ca.Sparsity.dense(*self._out)

    def has_eval_buffer(self) -> bool:
        return True

    def eval_buffer(self, args: tuple, res: tuple) -> int:
        try:
            out = self._fn(*(np.frombuffer(a, dtype=float) for a in args))
        except Late:
            return 1
        np.frombuffer(res[0], dtype=float)[:] = out
        return 0


class Answered(Wrapped):
    """``fn``, a function of the NLP that reaches ``cache``, evaluated with every point
    solved whatever the time: CasADi evaluates the point a solver's call returned once
    more after the call (the objective, rows and multipliers, ``nlp_grad``), and a
    refusal there would print a warning."""

    def __init__(self, fn: ca.Function, cache: IntervalCache) -> None:
        super().__init__(fn)
        self._cache = cache
        self.construct(fn.name(), {})

    def eval(self, args: list) -> list:
        with self._cache.answering():
            return self._fn.call(args)


def _triplets(matrix: ca.DM) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Rows, columns and values of the nonzeros of a constant sparse matrix."""
    r, col = (np.asarray(a, dtype=int) for a in matrix.sparsity().get_triplet())
    return r, col, np.asarray(matrix.nonzeros(), dtype=float)


def _rest(c: CondensedNlp) -> tuple[ca.Function, ca.Function, ca.DM]:
    """What is not an interval, differentiated whole: ``(w, p) -> (dg/dw, df/dw, df/ds)``,
    ``(w, p, lam_f, lam_g) -> (d2L/dw2 upper, dL/ds)`` and the constant ``dg/ds``.

    Raises
    ------
    ValueError
        When the NLP is not linear in the intervals' outputs with coefficients free of the
        variables (then the interval-wise chain rule would be wrong).
    """
    w, p, s = c.w_s, c.p_s, ca.vec(c.s)
    lam_f, lam_g = ca.SX.sym("lam_f"), ca.SX.sym("lam_g", c.n_g)
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
    return rest, rest_hess, ca.DM(ca.Function("jac_s", [], [jac_s])()["o0"])


def condensed_derivatives(c: CondensedNlp,
                          compile_fn: Callable[[ca.Function], ca.Function] | None = None
                          ) -> tuple[Derivatives, tuple[ca.Callback, ...]]:
    """The condensed NLP's objective, rows, gradient, Jacobian and Lagrangian Hessian
    (upper triangle), with every interval solved once per point; ``compile_fn``, when
    given, compiles the interval functions.

    Returns the derivatives and the callbacks into their :class:`IntervalCache` (keep
    them as long as the functions live: CasADi holds no reference to them).
    """
    t0 = time.perf_counter()
    n_y, n = c.s.shape
    n_w, n_g, n_q = c.n_w, c.n_g, c.interval.n_q
    rest, rest_hess, jac_s = _rest(c)
    fns = interval_functions(c.interval)
    cache = IntervalCache(c, fns if compile_fn is None else fns.compiled(compile_fn))
    n_p = c.p_s.shape[0]
    calls = (_Call("interval_outputs", cache.outputs, [(n_w, 1), (n_p, 1)], (n_y, n)),
             _Call("interval_jacobians", cache.jacobian, [(n_w, 1), (n_p, 1)],
                   (n_y * n_q, n)),
             _Call("interval_hessians", cache.hessian, [(n_w, 1), (n_p, 1), (n_y, n)],
                   (n_q * n_q, n)))
    # the interval Jacobians' nonzeros (dense n_y x n_q blocks, interval after interval):
    # output i of interval k, variable j at nonzero k n_y n_q + j n_y + i, column i_q[j, k]
    rows_s, cols_s, coef = _triplets(jac_s)
    k, i = np.divmod(cols_s[:, None], n_y)
    j = np.arange(n_q)[None, :]
    t = (k * n_y * n_q + j * n_y + i).ravel()
    jac_cols = c.i_q[j, k].ravel()
    jac_rows = np.repeat(rows_s, n_q)
    jac_coef = ca.DM(np.repeat(coef, n_q))
    ks, is_ = np.divmod(np.arange(n_y * n), n_y)
    t_grad = (ks[:, None] * n_y * n_q + j * n_y + is_[:, None]).ravel()
    hr, hc = local_entries(ca.Sparsity.dense(n_q, n_q), c.i_q)
    hr = np.where(hr <= hc, hr, -1)  # the upper triangle, as IPOPT takes it

    x_, p_ = ca.MX.sym("x", n_w), ca.MX.sym("p", n_p)
    lf_, lg_ = ca.MX.sym("lam_f"), ca.MX.sym("lam_g", n_g)
    jac_nz = ca.vec(calls[1](x_, p_))
    fg = ca.Function("f_g_s", [c.w_s, c.p_s, ca.vec(c.s)], [c.f_s, c.g_s])
    f_, g_ = fg(x_, p_, ca.vec(calls[0](x_, p_)))
    jac_w, grad_w, grad_s_f = rest(x_, p_)
    jac = sum_into((n_g, n_w), [entries(jac_w), (jac_coef * jac_nz[t.tolist()], jac_rows,
                                                    jac_cols)])
    per_variable = ca.vec(ca.repmat(grad_s_f.T, n_q, 1))  # d f / d s, once per variable
    grad = grad_w + sum_into((n_w, 1), [(jac_nz[t_grad.tolist()] * per_variable,
                                          c.i_q[np.tile(np.arange(n_q), n_y * n),
                                                np.repeat(ks, n_q)],
                                          np.zeros(n_y * n * n_q, dtype=int))])
    hess_rest, nu_ = rest_hess(x_, p_, lf_, lg_)
    hess_nz = calls[2](x_, p_, ca.reshape(nu_, n_y, n))
    hess = sum_into((n_w, n_w), [(ca.vec(hess_nz), hr, hc), entries(hess_rest)])
    log.debug("condensed NLP derivatives in %.1f s", time.perf_counter() - t0)
    return Derivatives(x_, p_, lf_, lg_, f_, grad, g_, jac, hess), calls
