"""What a transcription needs of a cycle OCP: the contract between a formulation and
:mod:`optimize.problem.transcriptions`.

A formulation states what is optimized, in continuous time and scaled: its model
(:class:`optimize.model.dae.Dae`), the constraint rows at one point of the cycle,
at its start and between its start and end, the integrands of the cycle averages,
the objective and the bounds of the variables. The kite's formulation
(:class:`optimize.problem.formulation.Formulation`) is one; a new model brings its
own module with one more, and the transcriptions, the solvers and the solve path
take it unchanged.

A constraint row is a :class:`Row`: a name, a scaled expression and its bounds,
with separate bounds when the drive limits apply (the ``*-lim`` scenarios). The
transcriptions place a point's rows at every collocation point and find rows by name.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from optimize.model.dae import Dae


@dataclass(frozen=True)
class Row:
    """Constraint rows ``lo <= expr <= hi`` (scaled).

    Attributes
    ----------
    name : str
        What the rows constrain (the transcription's index of the rows).
    expr : casadi.SX
        Column of scaled expressions.
    lo, hi : float
        Bounds (each row the same) without the drive limits.
    limited : (float, float) or None
        Bounds when the drive limits apply; ``None``: the same as ``(lo, hi)``.
    """

    name: str
    expr: Any
    lo: float = 0.0
    hi: float = 0.0
    limited: tuple[float, float] | None = None


@dataclass(frozen=True)
class Point:
    """What a formulation asks of one collocation point.

    Attributes
    ----------
    rows : list of Row
        Its path constraints.
    averages : dict
        Integrand per cycle average, in the order of the formulation's ``averages``
        (the transcription integrates each by the collocation's quadrature).
    fict_sq : casadi.SX
        Sum of the squared scaled fictitious forces (the homotopy's penalty).
    """

    rows: list[Row]
    averages: dict[str, Any]
    fict_sq: Any


class VariableScales(Protocol):
    """Typical magnitudes [SI] the decision variables are divided by."""

    state: np.ndarray
    control: np.ndarray
    algebraic: np.ndarray
    fictitious: np.ndarray
    period_s: float


class CycleFormulation(Protocol):
    """A periodic OCP as the transcriptions take it (all expressions scaled).

    Attributes
    ----------
    dae : Dae
        The model: sizes and names of its vectors, its dynamics.
    parameters : tuple of str
        The model's scalar parameters, set per scenario (the kite's reference wind speed
        ``wind_speed_m_s``; NLP parameters of the same names, first in ``p``).
    scales : VariableScales
    averages : tuple of str
        Names of the cycle averages of :attr:`Point.averages`.
    objective_averages : tuple of str
        The averages the objective can weight (one NLP parameter ``w_<name>`` each).
    constrained_averages : tuple of str
        The averages :meth:`average_rows` constrains (carried as running integrals
        by the stage-wise layout).
    objective_scale : float
        The objective's weighted averages are divided by this.
    """

    dae: Dae
    parameters: tuple[str, ...]
    scales: VariableScales
    averages: tuple[str, ...]
    objective_averages: tuple[str, ...]
    constrained_averages: tuple[str, ...]
    objective_scale: float

    def ode(self, x: Any, u: Any, z: Any) -> Any:
        """``xdot = f(x, u, z)`` (physical units)."""

    def point(self, x: Any, u: Any, z: Any, fict: Any, params: Any) -> Point:
        """Rows and integrands at one collocation point (physical arguments; ``params``
        the values of :attr:`parameters`)."""

    def trajectory_outputs(self, x: np.ndarray, u: np.ndarray, z: np.ndarray,
                           params: Any) -> dict[str, np.ndarray]:
        """Derived columns of a solution's trajectory at points (columns of ``x, u, z``;
        ``params`` the values of :attr:`parameters`), each name ending in its unit."""

    def control_cost(self, u: Any) -> Any:
        """Regularization of one interval's control (physical)."""

    def start_rows(self, x0: Any) -> list[Row]:
        """Rows at t = 0."""

    def periodicity_rows(self, x0: Any, x_end: Any) -> list[Row]:
        """Rows that close the cycle."""

    def average_rows(self, averages: dict[str, Any]) -> list[Row]:
        """Rows on the cycle averages named in :attr:`constrained_averages`."""

    def objective(self, weights: dict[str, Any], averages: dict[str, Any],
                  regularization: Any, tracking: Any, fict_penalty: Any) -> Any:
        """Scaled objective; ``weights`` holds the NLP's weight parameters by name."""

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper state bounds [SI]."""

    def start_state_fixed(self) -> dict[int, float]:
        """State components fixed at t = 0 [SI]."""

    def limited_state_bounds(self) -> dict[int, tuple[float, float]]:
        """State bounds that replace :meth:`state_bounds` under the drive limits [SI]."""

    def algebraic_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of the algebraic variables [SI]."""

    def control_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of the controls [SI]."""

    def period_bounds(self) -> tuple[float, float]:
        """Bounds of the free period [s]."""


#: NLP parameters every transcription has besides the model's parameters and the
#: objective weights: the weights of the regularization and the homotopy terms
BASE_PARAMS = ("w_reg", "w_track", "w_fict")


def weight_param(average: str) -> str:
    """Name of the NLP parameter that weights the cycle average ``average``."""
    return f"w_{average}"


def param_names(form: CycleFormulation) -> tuple[str, ...]:
    """The scalar NLP parameters of a formulation, in the order of the vector ``p``: the
    model's parameters, the objective weights, :data:`BASE_PARAMS`."""
    return (*form.parameters, *(weight_param(a) for a in form.objective_averages),
            *BASE_PARAMS)
