"""The collocation method: every Radau point's states and algebraic variables are NLP
variables (:mod:`optimize.problem.transcriptions.layouts`), in the general layout for a
general sparse solver or in stages for a stage-wise one (fatrop); its derivatives point
by point (:mod:`optimize.problem.transcriptions.derivatives`).
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from optimize.problem.collocation import Collocation
from optimize.problem.interface import CycleFormulation
from optimize.problem.options import Discretization, SolverOptions
from optimize.problem.transcriptions.derivatives import nlp_derivatives
from optimize.problem.transcriptions.gate import Gated
from optimize.problem.transcriptions.layouts import general_layout, stagewise_layout
from optimize.problem.transcriptions.method import Call, SolverNlp, compile_fn
from optimize.problem.transcriptions.structure import Transcription


def full_derivatives(ocp: Any, solver: str) -> dict[str, ca.Function]:
    """The derivative functions of ``ocp``'s own NLP in ``solver``'s format (built once
    per format, cached on the OCP; every solver instance of the OCP takes them, so a
    warm-start solver costs about a second to create instead of repeating the
    differentiation)."""
    key = ("derivatives", solver)
    if key not in ocp.solvers:
        ocp.solvers[key] = nlp_derivatives(ocp.transcription, solver, compile_fn(ocp))
    return ocp.solvers[key]


class CollocationMethod:
    """Direct collocation (a :class:`optimize.problem.transcriptions.method.Method`)."""

    name = "collocation"

    def transcribe(self, form: CycleFormulation, disc: Discretization, coll: Collocation,
                   solver: SolverOptions) -> Transcription:
        """The stage-wise layout for a stage-wise solver, else the general one."""
        layout = stagewise_layout if solver.stagewise else general_layout
        return layout(form, disc, coll)

    def solver_nlp(self, ocp: Any, solver: str) -> SolverNlp:
        """The OCP's own NLP with its point-by-point derivatives; fatrop's constraint
        Jacobian refused past the thread's deadline (:class:`Gated`: fatrop has no time
        limit of its own, IPOPT its ``max_wall_time``)."""
        functions = full_derivatives(ocp, solver)
        if solver == "fatrop":
            if "fatrop_gate" not in ocp.solvers:  # lives as long as the solvers calling it
                ocp.solvers["fatrop_gate"] = Gated(functions["nlp_jac_g"])
            functions = {**functions, "nlp_jac_g": ocp.solvers["fatrop_gate"]}
        return SolverNlp(ocp.nlp, functions, [bool(e) for e in ocp.layout.equality])

    def solve(self, ocp: Any, call: Call, w0: np.ndarray, p: np.ndarray, bounds: tuple,
              lam_x0: np.ndarray | None, lam_g0: np.ndarray | None) -> Any:
        """The solver's call as it is."""
        return call(w0, p, bounds, lam_x0, lam_g0)
