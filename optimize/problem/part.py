"""A model part: what one piece of the physics brings to the cycle OCP.

The kite's OCP is a list of parts (:func:`optimize.problem.parts.kite_parts`): the kite
(:class:`optimize.problem.kite_part.KitePart`), its drivetrain and drive
(:class:`optimize.problem.drive_part.DrivePart`) and, with a thermal rating, the
winding temperature (:class:`optimize.problem.thermal_part.ThermalPart`). The
formulation (:class:`optimize.problem.formulation.Formulation`), the transcriptions,
the scaling, the start guess, the trajectory frame (``trajectories.parquet``'s columns)
and the summary's active bounds iterate over the parts; none of them names a part's
variable.

Writing a part
--------------
Subclass :class:`Part` (usually as a frozen dataclass holding its parameters) and
override what the part has; every method has a default that adds nothing.

Variables (class or instance attributes, :class:`optimize.model.variables.Variables`,
every name ending in its unit suffix, no name used by another part):
``states``, ``controls``, ``algebraic``, ``fictitious`` (the homotopy's forces, zero in
the physical model), ``parameters`` (scalars set per scenario, NLP parameters of the
same names: the kite's reference wind ``wind_speed_m_s``), and ``periodic``, the names of
the own states that repeat over a cycle.

Quantities: at a point of the cycle the formulation builds a dict ``q`` of named
CasADi expressions (physical units): every variable and parameter of every part by
name, then what each part's :meth:`Part.quantities`
returns, part after part in the order of the list (a part reads the quantities of
the parts before it; it may replace one of theirs, as the thermal part puts the
copper loss at the winding temperature into ``p_elec_w``). The kite gives
``tension_n``, ``airspeed_m_s``, ``alpha_rad``, ...; the drive ``speed_rpm``,
``torque_nm``, ``p_mech_w``, ``p_elec_w``. A part puts a force or moment on the kite
by adding to the quantities :data:`optimize.problem.kite_part.EXTERNAL` (``f_ext_x_n``
... in the world NED frame, ``m_ext_x_nm`` ... in the body frame): return
``{"f_ext_z_n": q.get("f_ext_z_n", 0) + mine}``. Then, on the finished ``q``:

* :meth:`Part.rates`: ``d/dt`` of the own states, in their order (they may not depend
  on the parameters: the model's ``ode`` is ``(x, u, z) -> xdot``);
* :meth:`Part.residual`: rows of the algebraic residual ``0 = g`` (affine in the
  algebraic variables; one row per own algebraic variable in all);
* :meth:`Part.rows`: path constraints (:class:`optimize.problem.interface.Row`,
  scaled), placed at every collocation point;
* :meth:`Part.averages`: integrands of the cycle averages it defines (named in
  ``cycle_averages``; those the objective can weight in ``objective_averages``);
* :meth:`Part.outputs`: trajectory columns (``trajectories.parquet``), the ones the
  part declares in ``output_columns`` (each name ending in its unit suffix,
  :func:`kernel.units.unit_of`: the column's unit), in that order; so a sweep in which
  nothing converged still has every column (:func:`trajectory_columns`);
* :meth:`Part.figures`: the part's figures of a solved cycle for the summary
  (``summary.parquet``), from the trajectory table (the thermal part's peak winding
  temperature and its margin to the limit).

Bounds and scales, by variable name [SI]: :meth:`Part.bounds` (default unbounded),
:meth:`Part.active_bounds` (the names of its bounds an optimum sits on, for the summary),
:meth:`Part.limited_bounds` (replacing those under the drive limits; may name another
part's state), :meth:`Part.scales` (the typical magnitude each variable is divided by;
default 1). The cycle: :meth:`Part.start_rows`, :meth:`Part.periodicity_rows` (beyond
the periodic states), :meth:`Part.average_rows`, :meth:`Part.start_fixed`.

Start: :meth:`Part.guess` fills the part's own variables from a
:class:`StartPoint` (the quantities of the parts before it along a start trajectory).
A stored initial guess or the homotopy's circular loop gives the kite's variables; the
parts after it fill theirs, so a stored guess keeps working when a part is added.

The stored initial guess records the parts it holds (their names and variables,
:func:`optimize.solve.starts.stored_guess.parts_record`); it is checked on the OCP's parts of
those names, then carried over: a part the file lacks fills its own variables (a part
that only adds variables and rows keeps the kite's optimum; one that changes the kite's
or the drive's own rows, a force on the kite, starts from it all the same, its rows not
yet satisfied there); a part the file holds and the OCP has not, or has with other
variables, refuses the file (the homotopy starts instead, and the log says why).

Inputs: a part with inputs of its own declares its section of the system file, a frozen
dataclass of keys with their units, ranges, defaults and meanings (:mod:`kernel.sections`)
whose ``part(dae, scales)`` makes the part from them (``dae`` the kite's
:class:`optimize.model.kite_model.KiteDae`, ``scales`` the system's
:class:`optimize.problem.scaling.Scales`).

Registering: one line in :data:`optimize.problem.part_sections.PART_SECTIONS`, the section's name
and class: a system file with that section then flies the part in every solve of
``bench optimize``, ``bench aep --refine`` and ``bench size``, the file's reader checks
its keys, and docs/system_file.md shows them. A part without inputs is passed to
:func:`optimize.problem.ocp.build_ocp` (``parts=``) or appended in
:func:`optimize.problem.parts.kite_parts`. A complete example, a filter of the reel speed
with its section, state, bound, scale, output and start: ``ReelFilter`` in
tests/test_model_parts.py.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from kernel.units import unit_of
from optimize.model.variables import Variables

#: no variables
NONE = Variables(())
#: a bound counts as active within this fraction of its value (IPOPT's bound push and
#: tolerance leave the optimum about 1e-8 to 1e-6 inside)
ACTIVE_RTOL = 1e-3


def near(value: Any, bound: float | None) -> bool:
    """Whether ``value`` (an array along the cycle) reaches ``bound`` anywhere, within
    :data:`ACTIVE_RTOL` of it (None or an infinite bound: no)."""
    return bound is not None and bool(np.isfinite(bound)) and bool(
        np.any(np.abs(np.asarray(value, dtype=float) - bound)
               <= ACTIVE_RTOL * max(abs(bound), 1e-9)))


@dataclass(frozen=True)
class StartPoint:
    """What a part's :meth:`Part.guess` sees: a start trajectory of the parts before it.

    Attributes
    ----------
    grid_times_s : ndarray (N d + 1,)
        Times [s] of the state grid points (interval starts and Radau points).
    period_s : float
        The start's period [s].
    n_intervals : int
        Collocation intervals per period ``N``.
    parameters : dict of float
        The model's parameters by name (the reference wind speed ``wind_speed_m_s`` [m/s]).
    quantities : dict of ndarray
        The variables and quantities of the parts before this one at the ``N d``
        Radau points (``time_s`` in ``(0, T]``, the last one is the period's end).
    """

    grid_times_s: np.ndarray
    period_s: float
    n_intervals: int
    parameters: Mapping[str, float]
    quantities: Mapping[str, np.ndarray]

    @property
    def times_s(self) -> np.ndarray:
        """Times [s] of the Radau points (the columns of :attr:`quantities`)."""
        return self.grid_times_s[1:]

    @staticmethod
    def on_grid(at_points: np.ndarray) -> np.ndarray:
        """Values at the Radau points extended to the state grid: the periodic value at
        ``t = 0`` is the one at the period's end (the last point)."""
        arr = np.asarray(at_points, dtype=float)
        return np.concatenate([arr[..., -1:], arr], axis=-1)


class Part:
    """One piece of the physics of the cycle OCP (see the module docstring).

    Every method adds nothing by default; a part overrides what it has. Variables:
    ``states``, ``controls``, ``algebraic``, ``fictitious`` (``Variables``) and
    ``periodic`` (names of own states).
    """

    name: str = "part"
    states: Variables = NONE
    controls: Variables = NONE
    algebraic: Variables = NONE
    fictitious: Variables = NONE
    parameters: Variables = NONE
    periodic: tuple[str, ...] = ()
    #: the trajectory columns :meth:`outputs` gives, in its order, each name ending in
    #: its unit suffix (:func:`kernel.units.unit_of`)
    output_columns: tuple[str, ...] = ()
    #: the names of the cycle averages :meth:`averages` defines, and those of them the
    #: objective can weight
    cycle_averages: tuple[str, ...] = ()
    objective_averages: tuple[str, ...] = ()

    def quantities(self, q: Mapping[str, Any]) -> dict[str, Any]:
        """Named quantities this part derives at a point from ``q`` (physical units)."""
        return {}

    def rates(self, q: Mapping[str, Any]) -> list[Any]:
        """``d/dt`` of the own states, in their order (physical units)."""
        return []

    def residual(self, q: Mapping[str, Any]) -> list[Any]:
        """Rows of the algebraic residual (scaled), affine in the algebraic variables."""
        return []

    def rows(self, q: Mapping[str, Any]) -> list[Any]:
        """Path constraints at a point (``Row``, scaled)."""
        return []

    def averages(self, q: Mapping[str, Any]) -> dict[str, Any]:
        """Integrands of the cycle averages this part defines, by name."""
        return {}

    def outputs(self, q: Mapping[str, Any]) -> dict[str, Any]:
        """Trajectory columns at a point: those of :attr:`output_columns`, by name."""
        return {}

    def figures(self, traj: Any) -> dict[str, float]:
        """The part's figures of a solved cycle for the summary, each name ending in its
        unit, from its trajectory table (``trajectories.parquet``'s columns)."""
        return {}

    def bounds(self) -> dict[str, tuple[float, float]]:
        """Bounds of the own variables [SI] (default: none)."""
        return {}

    def limited_bounds(self) -> dict[str, tuple[float, float]]:
        """State bounds [SI] that replace :meth:`bounds` under the drive limits."""
        return {}

    def scales(self) -> dict[str, float]:
        """Typical magnitude [SI] of each own variable (default 1)."""
        return {}

    def start_rows(self, q0: Mapping[str, Any]) -> list[Any]:
        """Rows at ``t = 0`` on the start state's components ``q0`` (by name)."""
        return []

    def periodicity_rows(self, q0: Mapping[str, Any], q_end: Mapping[str, Any]) -> list[Any]:
        """Rows that close the cycle besides the periodic states (by name at both ends)."""
        return []

    def average_rows(self, averages: Mapping[str, Any]) -> list[Any]:
        """Rows on the cycle averages (by name)."""
        return []

    def constrained_averages(self) -> tuple[str, ...]:
        """The averages :meth:`average_rows` constrains."""
        return ()

    def start_fixed(self) -> dict[str, float]:
        """Own state components fixed at ``t = 0`` [SI]."""
        return {}

    def active_bounds(self, traj: Any, drive_limits: bool) -> list[str]:
        """Names of this part's bounds a solution's trajectory (its table,
        ``trajectories.parquet``'s columns) sits on (:func:`near`); ``drive_limits``:
        whether the drive limits applied."""
        return []

    def guess(self, start: StartPoint) -> dict[str, np.ndarray]:
        """Start values of the own variables: states ``(N d + 1,)`` at the state grid,
        algebraic variables and fictitious forces ``(N d,)`` at the Radau points,
        controls ``(N,)`` per interval; a variable left out starts at zero."""
        return {}


#: the trajectory table's own columns before the parts' (time [s], collocation interval,
#: quadrature weight)
FRAME_COLUMNS = ("time_s", "interval", "weight")


def trajectory_columns(parts: tuple[Part, ...]) -> dict[str, str]:
    """The columns of the trajectory table of an OCP of ``parts``, in order, with their
    units: :data:`FRAME_COLUMNS`, then every part's states, controls and algebraic
    variables (the parts' order within each vector), then every part's
    ``output_columns``.

    Raises
    ------
    ValueError
        A part's variable or output column whose name carries no unit suffix
        (:func:`kernel.units.unit_of`), or a name two parts give.
    """
    own = [(p.name, n) for group in ("states", "controls", "algebraic") for p in parts
           for n in getattr(p, group).names]
    own += [(p.name, n) for p in parts for n in p.output_columns]
    out = {name: unit_of(name) for name in FRAME_COLUMNS}
    for part, name in own:
        if not unit_of(name):
            raise ValueError(f"part {part!r}: column {name!r} has no unit suffix "
                             "(kernel.units.UNIT_SUFFIXES)")
        if name in out:
            raise ValueError(f"part {part!r}: column {name!r} is given twice")
        out[name] = unit_of(name)
    return out


def variables_of(parts: tuple[Part, ...], vector: str) -> Variables:
    """All parts' variables of one vector (``"states"``, ``"controls"``, ``"algebraic"``,
    ``"fictitious"``, ``"parameters"``), in the order of the parts."""
    return Variables(tuple(n for p in parts for n in getattr(p, vector).names))
