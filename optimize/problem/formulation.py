"""The kite's periodic pumping-cycle OCP in continuous time (paper section IV, eq. 5),
put together from its parts.

What is optimized and subject to what, independent of how it is transcribed: the
model, the path constraints at a point of the cycle, the conditions at the cycle's
start and between its start and end (invariants, periodicity), the cycle averages and
the objective, and the bounds of the variables. Each of these is the parts' (a list of
:class:`optimize.problem.part.Part`: the kite, the drive, the winding temperature; see
:func:`optimize.problem.parts.kite_parts`); this module only iterates over them and
names none of their variables. Everything is returned scaled (each expression divided
by its typical size, :mod:`optimize.problem.scaling`). :class:`Formulation` implements
:class:`optimize.problem.interface.CycleFormulation`.
"""

from __future__ import annotations

import dataclasses
import functools
import operator
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from optimize.model.variables import Variables
from optimize.problem.interface import Point, Row, weight_param
from optimize.problem.options import Discretization
from optimize.problem.part import Part, variables_of
from optimize.problem.scaling import Scales

#: the vectors of a model's variables, in the order of the point's arguments
VARIABLE_VECTORS = ("states", "controls", "algebraic", "fictitious")
#: the vectors of a point: the variables, then the model's parameters
VECTORS = (*VARIABLE_VECTORS, "parameters")


def _named(variables: Variables, vector: Any) -> dict[str, Any]:
    return {name: vector[i] for i, name in enumerate(variables.names)}


@dataclass(frozen=True)
class PartsModel:
    """The model of a list of parts (a :class:`optimize.model.dae.Dae`): their variables
    in the parts' order, the kite's parameters and CasADi functions of the whole.

    Attributes
    ----------
    kite, coeffs, wind
        The kite's parameters (of the first part's model).
    states, controls, algebraic, fictitious, parameters : Variables
    periodic : tuple of str
    ode : casadi.Function
        ``(x, u, z) -> xdot``, the parts' rates.
    alg : casadi.Function
        ``(x, u, z, p, fict) -> residual`` (scaled), the parts' residuals.
    explicit_ode : casadi.Function
        ``(x, u, p) -> xdot`` with ``z`` solved from ``alg``.
    solve_z : casadi.Function
        ``(x, u, p) -> z``.
    """

    kite: Any
    coeffs: Any
    wind: Any
    states: Variables
    controls: Variables
    algebraic: Variables
    fictitious: Variables
    parameters: Variables
    periodic: tuple[str, ...]
    ode: ca.Function
    alg: ca.Function
    explicit_ode: ca.Function
    solve_z: ca.Function


def parts_model(parts: tuple[Part, ...]) -> Any:
    """The model of ``parts``; the first part's own model (``parts[0].dae``) when no
    other part has variables."""
    first = parts[0]
    if all(getattr(p, k).size == 0 for p in parts[1:] for k in VECTORS):
        return first.dae
    v = {k: variables_of(parts, k) for k in VECTORS}
    x, u = ca.SX.sym("x", v["states"].size), ca.SX.sym("u", v["controls"].size)
    z, fict = ca.SX.sym("z", v["algebraic"].size), ca.SX.sym("fict", v["fictitious"].size)
    par = ca.SX.sym("p", v["parameters"].size)
    q = point_quantities(parts, x, u, z, fict, par)
    xdot = ca.vertcat(*[r for p in parts for r in p.rates(q)])
    residual = ca.vertcat(*[r for p in parts for r in p.residual(q)])
    ode = ca.Function("ode", [x, u, z], [xdot], ["x", "u", "z"], ["xdot"])
    # the residual is affine in z: z = -A^{-1} residual(z = 0, fict = 0)
    res0 = ca.substitute(residual, ca.vertcat(z, fict), ca.DM.zeros(z.numel() + fict.numel()))
    jac0 = ca.substitute(ca.jacobian(residual, z), fict, ca.DM.zeros(fict.numel()))
    z_phys = -ca.solve(jac0, res0)
    return PartsModel(
        kite=first.dae.kite, coeffs=first.dae.coeffs, wind=first.dae.wind,
        periodic=tuple(n for p in parts for n in p.periodic),
        ode=ode, alg=ca.Function("alg", [x, u, z, par, fict], [residual]),
        explicit_ode=ca.Function("explicit_ode", [x, u, par], [ode(x, u, z_phys)]),
        solve_z=ca.Function("solve_z", [x, u, par], [z_phys]), **v)


def point_quantities(parts: tuple[Part, ...], x: Any, u: Any, z: Any, fict: Any,
                     params: Any, upto: int | None = None) -> dict[str, Any]:
    """The named quantities at a point: every variable and parameter, then each part's
    :meth:`optimize.problem.part.Part.quantities` in order (of ``parts[:upto]``)."""
    q: dict[str, Any] = {}
    for group, vector in zip(VECTORS, (x, u, z, fict, params), strict=True):
        q.update(_named(variables_of(parts, group), vector))
    for part in parts[:upto]:
        q.update(part.quantities(q))
    return q


@dataclass(frozen=True)
class Formulation:
    """The cycle OCP of a list of parts (pure: builds expressions only).

    Parameters
    ----------
    parts : tuple of Part
        The kite first (its model gives the kite's parameters), then the parts that
        read its quantities.
    discretization : Discretization
        For the control regularization's weight and scales.
    scales : Scales
        The system's magnitudes; the per-variable scales are set from the parts.
    """

    parts: tuple[Part, ...]
    discretization: Discretization
    scales: Scales
    dae: Any = field(init=False)

    def __post_init__(self) -> None:
        names = [n for p in self.parts for k in VECTORS for n in getattr(p, k).names]
        if len(set(names)) != len(names):
            raise ValueError(f"two parts name the same variable: {sorted(names)}")
        object.__setattr__(self, "dae", parts_model(self.parts))
        values = {n: v for p in self.parts for n, v in p.scales().items()}
        per_vector = {group: np.array([float(values.get(n, 1.0))
                                       for n in getattr(self.dae, group).names])
                      for group in VARIABLE_VECTORS}
        object.__setattr__(self, "scales", dataclasses.replace(
            self.scales, state=per_vector["states"], control=per_vector["controls"],
            algebraic=per_vector["algebraic"], fictitious=per_vector["fictitious"]))

    def part(self, name: str) -> Part | None:
        """The part called ``name`` (None when the formulation has none)."""
        return next((p for p in self.parts if p.name == name), None)

    @property
    def drive_model(self) -> Any:
        """The drive's electrical power model (of the drive part)."""
        return self.part("drive").drive_model

    @property
    def thermal(self) -> Any:
        """The winding's thermal model (None without a thermal part)."""
        part = self.part("thermal")
        return None if part is None else part.thermal

    @property
    def parameters(self) -> tuple[str, ...]:
        """The model's parameters (the parts'), NLP parameters set per scenario."""
        return self.dae.parameters.names

    @property
    def averages(self) -> tuple[str, ...]:
        """The cycle averages of the parts."""
        return tuple(a for p in self.parts for a in p.cycle_averages)

    @property
    def objective_averages(self) -> tuple[str, ...]:
        """The averages the objective can weight."""
        return tuple(a for p in self.parts for a in p.objective_averages)

    @property
    def constrained_averages(self) -> tuple[str, ...]:
        """The averages the parts' average rows constrain."""
        return tuple(a for p in self.parts for a in p.constrained_averages())

    @property
    def objective_scale(self) -> float:
        """Power scale [W] of the objective's average powers."""
        return self.scales.power_w

    # ---------------------------------------------------------------- one point
    def ode(self, x: Any, u: Any, z: Any) -> Any:
        """``xdot = f(x, u, z)`` (physical units): the parts' rates."""
        return self.dae.ode(x, u, z)

    def quantities(self, x: Any, u: Any, z: Any, fict: Any, params: Any,
                   upto: int | None = None) -> dict[str, Any]:
        """The named quantities at a point (:func:`point_quantities`)."""
        return point_quantities(self.parts, x, u, z, fict, params, upto)

    def _symbols(self) -> tuple[Any, Any, Any, Any]:
        dae = self.dae
        return (ca.SX.sym("x", dae.states.size), ca.SX.sym("u", dae.controls.size),
                ca.SX.sym("z", dae.algebraic.size), ca.SX.sym("p", dae.parameters.size))

    def point(self, x: Any, u: Any, z: Any, fict: Any, params: Any) -> Point:
        """Rows and integrands at one collocation point (physical ``x, u, z, fict``, the
        model's ``params``): the parts' residual, then each part's rows."""
        q = self.quantities(x, u, z, fict, params)
        rows = [Row("algebraic", ca.vertcat(*[r for p in self.parts for r in p.residual(q)])),
                *(row for p in self.parts for row in p.rows(q))]
        averages: dict[str, Any] = {}
        for p in self.parts:
            averages.update(p.averages(q))
        return Point(rows=rows, averages={a: averages[a] for a in self.averages},
                     fict_sq=ca.sumsqr(fict / ca.DM(self.scales.fictitious)))

    @functools.cached_property
    def _outputs(self) -> ca.Function:
        x, u, z, par = self._symbols()
        q = self.quantities(x, u, z, ca.DM.zeros(self.dae.fictitious.size), par)
        out: dict[str, Any] = {}
        for p in self.parts:
            given = p.outputs(q)
            if tuple(given) != p.output_columns:
                raise ValueError(f"part {p.name!r}: outputs() gives {tuple(given)}, its "
                                 f"output_columns declare {p.output_columns}")
            out.update(given)
        return ca.Function("outputs", [x, u, z, par], list(out.values()),
                           ["x", "u", "z", "p"], list(out))

    @property
    def output_names(self) -> tuple[str, ...]:
        """The trajectory columns of the parts' outputs (their ``output_columns``), each
        name ending in its unit."""
        return tuple(self._outputs.name_out())

    def trajectory_outputs(self, x: np.ndarray, u: np.ndarray, z: np.ndarray,
                           params: Any) -> dict[str, np.ndarray]:
        """The parts' outputs at points (columns of ``x, u, z``; ``params`` the values of
        :attr:`parameters`): drive and flight quantities [SI, rpm, deg]."""
        out = self._outputs.map(x.shape[1])(x, u, z, params)
        return {name: np.asarray(val).ravel()
                for name, val in zip(self.output_names, out, strict=True)}

    def prefix_quantities(self, upto: int) -> tuple[ca.Function, tuple[str, ...]]:
        """``(x, u, z, p) -> q``: the scalar quantities of ``parts[:upto]`` (the
        variables first), and their names (for a part's start,
        :mod:`optimize.solve.starts.fill`)."""
        x, u, z, par = self._symbols()
        q = self.quantities(x, u, z, ca.DM.zeros(self.dae.fictitious.size), par, upto)
        for name in self.parameters:
            del q[name]
        return ca.Function("quantities", [x, u, z, par], [ca.vertcat(*q.values())],
                           ["x", "u", "z", "p"], ["q"]), tuple(q)

    def control_cost(self, u: Any) -> Any:
        """Regularization term of one interval's control ``sum_i (u_i / sigma_i)^2``."""
        return ca.sumsqr(u / ca.DM(self.discretization.control_sigma))

    # ---------------------------------------------------------------- cycle
    def start_rows(self, x0: Any) -> list[Row]:
        """The parts' rows at t = 0."""
        q0 = _named(self.dae.states, x0)
        return [row for p in self.parts for row in p.start_rows(q0)]

    def periodicity_rows(self, x0: Any, x_end: Any) -> list[Row]:
        """The cycle closes: the periodic states, then the parts' own closing rows."""
        per = self.dae.states.indices(self.dae.periodic)
        q0, q_end = _named(self.dae.states, x0), _named(self.dae.states, x_end)
        return [Row("periodic", (x_end[per] - x0[per]) * ca.DM(1.0 / self.scales.state[per])),
                *(row for p in self.parts for row in p.periodicity_rows(q0, q_end))]

    def average_rows(self, averages: dict[str, Any]) -> list[Row]:
        """The parts' rows on cycle averages."""
        return [row for p in self.parts for row in p.average_rows(averages)]

    def objective(self, weights: dict[str, Any], averages: dict[str, Any],
                  regularization: Any, tracking: Any, fict_penalty: Any) -> Any:
        """Scaled objective: weighted average powers, regularization and homotopy terms.

        ``weights`` holds the NLP's weight parameters by name
        (:func:`optimize.problem.interface.param_names`).
        """
        terms = [weights[weight_param(a)] * averages[a] for a in self.objective_averages]
        return (functools.reduce(operator.add, terms) / self.objective_scale
                + weights["w_reg"] * regularization
                + weights["w_track"] * tracking
                + weights["w_fict"] * fict_penalty)

    # ---------------------------------------------------------------- bounds
    def _bounds(self, variables: Variables) -> tuple[np.ndarray, np.ndarray]:
        given = {n: b for p in self.parts for n, b in p.bounds().items()}
        lo = np.array([given.get(n, (-np.inf, np.inf))[0] for n in variables.names], float)
        hi = np.array([given.get(n, (-np.inf, np.inf))[1] for n in variables.names], float)
        return lo, hi

    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the state [SI] (the parts')."""
        return self._bounds(self.dae.states)

    def start_state_fixed(self) -> dict[int, float]:
        """State components fixed at t = 0 [SI]."""
        return {self.dae.states.index(n): v for p in self.parts
                for n, v in p.start_fixed().items()}

    def limited_state_bounds(self) -> dict[int, tuple[float, float]]:
        """State bounds that replace :meth:`state_bounds` when the drive limits apply [SI]."""
        return {self.dae.states.index(n): b for p in self.parts
                for n, b in p.limited_bounds().items()}

    def algebraic_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of the algebraic variables [SI]."""
        return self._bounds(self.dae.algebraic)

    def control_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of the controls [SI]."""
        return self._bounds(self.dae.controls)

    def period_bounds(self) -> tuple[float, float]:
        """Bounds of the free period [s] (the kite's)."""
        return self.parts[0].period_bounds_s()
