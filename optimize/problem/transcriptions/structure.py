"""The structure of a transcribed NLP: its named decision vector, its index bookkeeping
(:class:`Layout`), its per-point structure (:class:`PointFunction`, :class:`PointBlocks`)
and the transcribed problem (:class:`Transcription`), shared by the collocation's layouts
(:mod:`optimize.problem.transcriptions.layouts`), its derivatives and the condensed NLP.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from optimize.problem.interface import CycleFormulation, Row


@dataclass
class Layout:
    """Index bookkeeping of the scaled decision, constraint and parameter vectors."""

    n_points: int  # grid points with states (N d + 1)
    n_coll: int  # Radau points (N d)
    i_period: np.ndarray  # (N,) one copy of the period per interval, all equal
    i_x: np.ndarray  # (NX, n_points) indices into w
    i_z: np.ndarray  # (NZ, n_coll)
    i_u: np.ndarray  # (NU, N)
    i_f: np.ndarray  # (NF, n_coll)
    scale_w: np.ndarray  # w_physical = scale_w * w_scaled
    n_w: int
    n_g: int
    n_p: int
    i_p_ref: np.ndarray  # (NX, n_points) reference trajectory in p
    params: dict[str, int] = field(default_factory=dict)  # scalar parameter -> index in p
    rows: dict[str, np.ndarray] = field(default_factory=dict)  # name -> indices into g
    name: str = "general"  # which layout: "general" or "stagewise"
    #: a function of the scaled ``w`` that sets the variables derived from others
    #: (copies, running integrals); ``None`` when there are none but the period copies
    complete: ca.Function | None = None
    #: per row, whether it is an equality in every configuration (lbg == ubg)
    equality: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=bool))
    #: the decision vector by name: each model variable (the period ``period_s``, every
    #: state, control, algebraic variable and fictitious force by its model name) -> its
    #: indices into ``w`` along the grid (:func:`named_variables`)
    variables: dict[str, np.ndarray] = field(default_factory=dict)

    def of(self, name: str) -> np.ndarray:
        """Indices into ``w`` of the variable ``name`` along the grid."""
        try:
            return self.variables[name]
        except KeyError:
            raise KeyError(f"no variable {name!r} in the decision vector; known: "
                           f"{', '.join(self.variables)}") from None

    def rows_of(self, name: str) -> np.ndarray:
        """Indices into ``g`` of the rows named ``name`` (empty when the NLP has none)."""
        return self.rows.get(name, np.zeros(0, dtype=int))


@dataclass(frozen=True)
class PointBlocks:
    """The NLP point by point: what :mod:`optimize.problem.transcriptions.derivatives` builds on.

    For each Radau point ``j``: ``g[rows[:, j]] = rows(w[vars[:, j]], p[i_params],
    deriv[:, j])`` of ``point.function``. Its integrands enter the objective and the
    other rows only through the cycle sums: ``f_s`` and ``g_s`` are ``f`` and ``g``
    with the symbols ``s`` (``(len(point.integrands), n_coll)``) in place of the integrands
    (``f = f_s`` and ``g = g_s`` once ``s`` is replaced by the points' integrands).
    """

    point: PointFunction
    vars: np.ndarray  # (n_v, n_coll) indices into w
    rows: np.ndarray  # (n_r, n_coll) indices into g
    deriv: np.ndarray  # (d + 1, n_coll) the points' columns of Collocation.deriv
    s: ca.SX
    f_s: ca.SX
    g_s: ca.SX
    i_params: np.ndarray  # indices in p of the model's parameters (``form.parameters``)


@dataclass
class Transcription:
    """A transcribed NLP: CasADi problem, layout and scaled base bounds.

    ``lbw, ubw, lbg, ubg`` hold without the drive limits, ``limited`` with them
    (both with the period free and the fictitious forces free).
    """

    nlp: dict
    layout: Layout
    lbw: np.ndarray
    ubw: np.ndarray
    lbg: np.ndarray
    ubg: np.ndarray
    limited: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    #: the per-point structure of the NLP (what its derivatives are built from)
    blocks: PointBlocks


@dataclass(frozen=True)
class PointFunction:
    """The rows and integrands of one Radau point as one CasADi function.

    ``function(v, params, deriv) -> (rows, integrands)``: ``v`` is the point's slice of
    the scaled decision vector in this order: period, state at the point, control,
    algebraic variables, fictitious forces, then the ``d + 1`` states of the interval
    (the point's own state appears twice; :func:`_interval` lays it out), ``params``
    the model's parameters (``form.parameters``, the kite's reference wind speed [m/s]),
    ``deriv`` the point's column of
    :attr:`Collocation.deriv`. ``rows`` are the dynamics rows then the formulation's
    point rows (``templates`` gives their names and bounds), ``integrands`` the values
    named by :attr:`integrands` (the formulation's cycle averages, then ``fict_sq``).
    Every Radau point of both layouts is this one function, so its derivatives can
    be built once (:mod:`optimize.problem.transcriptions.derivatives`).
    """

    function: ca.Function
    templates: tuple[Row, ...]
    integrands: tuple[str, ...]

    def rows_of(self, out: Any) -> list[Row]:
        """The point's rows with the expressions ``out`` (one call's ``rows``)."""
        rows, start = [], 0
        for t in self.templates:
            size = t.expr.shape[0]
            rows.append(Row(t.name, out[start:start + size], t.lo, t.hi, t.limited))
            start += size
        return rows


class Vector:
    """A vector laid out block by block, each block named (the decision vector of a
    layout: its indices come from here, in the order blocks are taken)."""

    def __init__(self) -> None:
        self.n = 0
        self.blocks: dict[str, list[np.ndarray]] = {}

    def take(self, name: str, size: int) -> np.ndarray:
        """The indices of the next ``size`` entries, a block of ``name``."""
        idx = np.arange(self.n, self.n + size, dtype=int)
        self.n += size
        self.blocks.setdefault(name, []).append(idx)
        return idx

    def columns(self, name: str, size: int, count: int) -> np.ndarray:
        """``count`` blocks of ``name`` one after the other, as ``(size, count)``."""
        return np.stack([self.take(name, size) for _ in range(count)], axis=1).reshape(
            size, count)


def named_variables(form: CycleFormulation, i_period: np.ndarray, i_x: np.ndarray,
                    i_z: np.ndarray, i_u: np.ndarray, i_f: np.ndarray) -> dict[str, np.ndarray]:
    """Each model variable's indices into ``w`` by its name (the period: ``period_s``)."""
    dae, out = form.dae, {"period_s": i_period}
    for variables, idx in ((dae.states, i_x), (dae.algebraic, i_z), (dae.controls, i_u),
                           (dae.fictitious, i_f)):
        out.update({name: idx[i] for i, name in enumerate(variables.names)})
    return out


def dims(form: CycleFormulation) -> tuple[int, int, int, int]:
    """Sizes of the model's state, algebraic, control and fictitious vectors."""
    dae = form.dae
    return dae.states.size, dae.algebraic.size, dae.controls.size, dae.fictitious.size
