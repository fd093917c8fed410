"""What a transcription method is: one object per method, behind one interface.

A method (:class:`Method`) turns a formulation into the NLP whose layout results,
starts and warm starts live in (:class:`optimize.problem.transcriptions.structure.Transcription`),
hands an NLP solver the problem it runs on with its derivatives (:class:`SolverNlp`),
and carries a start into that problem and its solution back (:meth:`Method.solve`).
:func:`optimize.problem.transcriptions.method_of` chooses it once from the solver
options; nothing else looks at the method's name.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import casadi as ca
import numpy as np

from optimize.problem.collocation import Collocation
from optimize.problem.interface import CycleFormulation
from optimize.problem.options import Discretization, SolverOptions
from optimize.problem.transcriptions.codegen import compiled
from optimize.problem.transcriptions.structure import Transcription

#: ``call(w0, p, bounds, lam_x0, lam_g0) -> RawSolve``: one call of the NLP solver
#: :mod:`optimize.solve.nlp_solver` created on :meth:`Method.solver_nlp`'s problem
Call = Callable[..., Any]


@dataclass(frozen=True)
class SolverNlp:
    """The problem an NLP solver runs and what it is handed with it.

    Attributes
    ----------
    nlp : dict
        ``{"x", "p", "f", "g"}``.
    functions : dict of casadi.Function
        Its derivatives in the solver's format
        (:data:`optimize.problem.transcriptions.derivatives.FORMATS`).
    cache : dict of casadi.Function
        Further functions the solver takes from its cache (the Lagrangian gradient of a
        problem CasADi cannot differentiate).
    options : dict
        Further ``nlpsol`` options.
    equality : list of bool
        Per row, whether it is an equality (fatrop's structure).
    """

    nlp: dict
    functions: dict
    equality: list
    cache: dict = field(default_factory=dict)
    options: dict = field(default_factory=dict)


class Method(Protocol):
    """One transcription method (``name``, a key of
    :data:`optimize.problem.options.TRANSCRIPTIONS`)."""

    name: str

    def transcribe(self, form: CycleFormulation, disc: Discretization, coll: Collocation,
                   solver: SolverOptions) -> Transcription:
        """The NLP in the layout the results live in (stage-wise for a stage-wise solver
        where the method has one)."""

    def solver_nlp(self, ocp: Any, solver: str) -> SolverNlp:
        """The problem ``solver`` runs for ``ocp`` (built once, cached on ``ocp``)."""

    def solve(self, ocp: Any, call: Call, w0: np.ndarray, p: np.ndarray, bounds: tuple,
              lam_x0: np.ndarray | None, lam_g0: np.ndarray | None) -> Any:
        """One solver call from the scaled start ``w0`` (and multipliers) of ``ocp``'s
        layout; the solution in that layout."""


def compile_fn(ocp: Any) -> Callable[[ca.Function], ca.Function] | None:
    """How the OCP's repeated functions are compiled:
    :func:`optimize.problem.transcriptions.codegen.compiled` when ``options.solver.codegen``
    is set, else not at all (None)."""
    return compiled if ocp.options.solver.codegen else None
