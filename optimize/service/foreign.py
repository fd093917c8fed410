"""Starts the solves did not find themselves: another problem's solution, a stored cycle, an
optimum with the period held.

A :class:`ForeignStart` is a converged solution of one problem (system, drive model,
options: :class:`optimize.service.builder.Problem`) offered as the first start of the
same scenario (kind and wind speed) of another problem. ``bench size`` offers each
candidate drive the reference drive's optimum at the same wind speed
(:func:`optimize.service.run.solve_tasks` with ``reference``): the candidates differ
from the reference only in the drive's losses and limits, which have no variables of
their own (:mod:`optimize.problem.drive_part`), so the reference's cycle is a point of
the candidate's NLP, feasible unless the candidate's limits cut it.

The solution crosses to the other problem's layout through the backend's ``carry``
(:meth:`optimize.service.builder.OcpBackend.carry`: every variable by name, the
multipliers of the rows both have); a backend without one (the tests' stand-ins)
takes the solution as it is.

A :class:`CycleStart` is a converged cycle of the same problem kept only as its
trajectory (``optimize_out/trajectories.parquet``, docs/schemas.md §5): ``bench aep
--refine`` starts each added wind speed from the nearest sweep speed this way
(:class:`optimize.service.chain.Refinement`). The backend's ``from_trajectory``
(:meth:`optimize.service.builder.OcpBackend.from_trajectory`) packs it into the NLP's
primal vector, with zero multipliers (the file keeps none).

A :class:`HeldStart` is an optimum of the same problem with its period held elsewhere
(:mod:`optimize.service.period_scan`), the start of a solve with the period free.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from optimize.problem.scenario import Scenario


@dataclass(frozen=True, eq=False)
class Start:
    """A start the solves did not find themselves (:class:`ForeignStart`, :class:`CycleStart`,
    :class:`HeldStart`).

    Attributes
    ----------
    scenario : Scenario
        The scenario it is the solution of.
    label : str
        How records name where it comes from (``"x1"``, ``"sweep"``).
    depth : int
        Its start-graph depth (0: a cold start).
    """

    scenario: Scenario
    label: str
    depth: int = 0

    @property
    def name(self) -> str:
        """``"x1 elec-lim-7.0"``: the attempts' and progress events' source."""
        return f"{self.label} {self.scenario.name}"

    def warm_from(self, kind: str) -> str:
        """The record's ``warm_from`` of a solve of ``kind`` started here: ``"x1 7 m/s"``
        (same kind) or :attr:`name`."""
        return (f"{self.label} {self.scenario.wind_speed_m_s:g} m/s"
                if kind == self.scenario.kind else self.name)

    def carried(self, backend: Any, ocp: Any) -> Any:
        """The start in the layout of ``ocp``, the NLP the solves run on."""
        raise NotImplementedError


@dataclass(frozen=True, eq=False)
class ForeignStart(Start):
    """A converged solution of another problem, offered as a start (picklable).

    Attributes
    ----------
    problem : optimize.service.builder.Problem
        The problem it solves.
    warm : Any
        Its primal and dual vectors (:class:`optimize.solve.result.Solution`, in the
        layout of ``problem``).
    (and those of :class:`Start`)
    """

    problem: Any = None
    warm: Any = None

    def carried(self, backend: Any, ocp: Any) -> Any:
        """The solution in the layout of ``ocp`` (another problem's built NLP), through
        ``backend.carry`` when the backend has one."""
        carry = getattr(backend, "carry", None)
        if carry is None:
            return self.warm
        return carry(backend.build(self.problem), self.warm, ocp, self.scenario)


@dataclass(frozen=True, eq=False)
class CycleStart(Start):
    """A converged cycle of the same problem, kept as its trajectory (picklable).

    Attributes
    ----------
    trajectory : pandas.DataFrame
        One row per Radau point: ``time_s`` and every state, control and algebraic
        variable of the model by name (docs/schemas.md §5 ``trajectories.parquet``).
    (and those of :class:`Start`)
    """

    trajectory: Any = None

    def carried(self, backend: Any, ocp: Any) -> Any:
        """The cycle as the NLP's start (``backend.from_trajectory``)."""
        return backend.from_trajectory(ocp, self.trajectory)


@dataclass(frozen=True, eq=False)
class HeldStart(Start):
    """An optimum of the same problem with the period held (picklable): the period
    scan's start (:mod:`optimize.service.period_scan`), solved again with the period free.

    Attributes
    ----------
    warm : Any
        Its primal and dual vectors (:class:`optimize.solve.result.Solution`).
    period_s : float
        The period it was held at [s].
    (and those of :class:`Start`)
    """

    warm: Any = None
    period_s: float = 0.0

    @property
    def name(self) -> str:
        """``"mech-free-10.0 held at 45 s"``: the attempts' and progress events' source."""
        return f"{self.scenario.name} held at {self.period_s:g} s"

    def warm_from(self, kind: str) -> str:
        """The record's ``warm_from``: ``"10 m/s held at 45 s"``."""
        return f"{self.scenario.wind_speed_m_s:g} m/s held at {self.period_s:g} s"

    def carried(self, backend: Any, ocp: Any) -> Any:
        """The held optimum as it is (the same NLP)."""
        return self.warm
