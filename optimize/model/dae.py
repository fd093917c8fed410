"""What a model of the cycle must provide: the semi-explicit DAE and its named vectors.

The transcription (:mod:`optimize.problem.transcriptions`) needs of a model only
this interface (through the formulation, :class:`optimize.problem.interface.CycleFormulation`):
the sizes and names of its vectors and the two CasADi functions of its dynamics.
The tethered kite (:mod:`optimize.model.kite_model`) is one such model; any other
(a point mass on a tether, a kite with a drivetrain or thermal state) is another.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import casadi as ca

from optimize.model.variables import Variables


class Dae(Protocol):
    """A semi-explicit DAE ``xdot = f(x, u, z)``, ``0 = g(x, u, z, p, fict)`` with the
    model's parameters ``p``.

    Attributes
    ----------
    states, controls, algebraic, parameters : Variables
        The named components of ``x``, ``u``, ``z`` and ``p`` (the kite's ``p`` is its
        reference wind speed).
    fictitious : Variables
        Fictitious forces and moments added to ``g`` by the initialization homotopy
        (zero in the physical model).
    ode : casadi.Function
        ``(x, u, z) -> xdot`` [SI].
    alg : casadi.Function
        ``(x, u, z, p, fict) -> residual`` (``algebraic.size`` rows).
    """

    states: Variables
    controls: Variables
    algebraic: Variables
    fictitious: Variables
    parameters: Variables
    ode: ca.Function
    alg: ca.Function


@dataclass(frozen=True)
class DaeSpec:
    """How a worker builds a model: a module-level factory and its picklable arguments
    (plain data crosses the process boundary, the CasADi functions are built there).

    Attributes
    ----------
    factory : callable
        ``factory(*args) -> Dae`` (e.g. :func:`optimize.model.kite_model.kite_dae`).
    args : tuple
        Its arguments (frozen parameter dataclasses).
    """

    factory: Callable[..., Dae]
    args: tuple = ()

    def build(self) -> Dae:
        """The model."""
        return self.factory(*self.args)
