"""The options of a sweep, grouped: which scenarios (:class:`WindGrid`), how each is
discretized and solved (:class:`SolverChoice`), where the solves run (:class:`Execution`).

``bench optimize``, ``bench aep --refine``, ``bench size`` and the Python API
(docs/python_api.md) build the same objects: the command line from its options
(:meth:`WindGrid.parse`), a Python caller directly.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from kernel.errors import InputError
from optimize.kinds import KINDS
from optimize.problem.deadline import CALL_WALL_LIMIT_S

#: the paper's wind grid [m/s] at the reference height (``bench optimize``'s default)
PAPER_WINDS_M_S = (4.0, 5.5, 7.0, 8.5, 10.0)


@dataclass(frozen=True)
class WindGrid:
    """The scenarios of a sweep: every kind at every wind speed.

    Attributes
    ----------
    wind_speeds_m_s : tuple of float
        Wind speeds at the reference height [m/s].
    kinds : tuple of str
        Scenario kinds (keys of :data:`optimize.kinds.KINDS`).

    Raises
    ------
    InputError
        No kind, an unknown kind, or no wind speed.
    """

    wind_speeds_m_s: tuple[float, ...] = PAPER_WINDS_M_S
    kinds: tuple[str, ...] = tuple(KINDS)

    def __post_init__(self) -> None:
        object.__setattr__(self, "wind_speeds_m_s", tuple(float(w) for w in self.wind_speeds_m_s))
        object.__setattr__(self, "kinds", tuple(self.kinds))
        unknown = [k for k in self.kinds if k not in KINDS]
        if unknown or not self.kinds:
            raise InputError(None, f"--scenarios {','.join(self.kinds)}: unknown scenario kinds "
                             f"{unknown or 'none given'}", expected=", ".join(KINDS))
        if not self.wind_speeds_m_s:
            raise InputError(None, "no wind speed", expected="at least one wind speed [m/s]")

    @classmethod
    def parse(cls, wind_grid: str, scenarios: str) -> WindGrid:
        """The grid of ``--wind-grid`` and ``--scenarios``
        (:func:`optimize.service.plan.parse_wind_grid`,
        :func:`optimize.service.plan.parse_kinds`)."""
        from optimize.service.plan import parse_kinds, parse_wind_grid

        return cls(parse_wind_grid(wind_grid), parse_kinds(scenarios))


@dataclass(frozen=True)
class SolverChoice:
    """How each scenario's optimal control problem is discretized and solved.

    Attributes
    ----------
    n_intervals, degree : int
        Collocation intervals and Radau polynomial degree (``--intervals``, ``--degree``).
    solver : str
        NLP solver (``--solver``: ``ipopt`` or ``fatrop``).
    linear_solver : str or None
        IPOPT's linear solver (``--linear-solver``; None: MUMPS).
    stored_guess : bool
        Start chains from the shipped initial guess (``--no-stored-guess``: False).
    transcription : str
        What the solver runs on (``--transcription``: ``collocation`` or ``condensed``,
        :attr:`optimize.problem.options.SolverOptions.transcription`).
    codegen : bool
        Compile the NLP's repeated functions to C (``--codegen``,
        :attr:`optimize.problem.options.SolverOptions.codegen`).
    start : Path or None
        The start of the sweep's cold start in place of the shipped initial guess
        (``--start``): an earlier sweep's ``start.npz`` of the same system, or its folder.
    call_time_limit_s : float
        The longest one solver call may run [s] (``--call-time-limit``,
        :attr:`optimize.problem.options.SolverOptions.call_time_limit_s`).
    """

    n_intervals: int = 40
    degree: int = 4
    solver: str = "ipopt"
    linear_solver: str | None = None
    stored_guess: bool = True
    transcription: str = "collocation"
    codegen: bool = False
    start: Path | None = None
    call_time_limit_s: float = CALL_WALL_LIMIT_S


#: why a sweep runs on as many workers as it does (:attr:`Execution.workers_reason`)
CORES_REASON, GIVEN_REASON = "the cores this process may use", "--workers"


def usable_cores() -> int:
    """The cores this process may run on: its CPU affinity mask (a container's or a
    ``taskset``'s share), else the machine's count where the platform has no mask."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # no affinity mask on this platform (macOS, Windows)
        return os.cpu_count() or 1


@dataclass(frozen=True)
class Execution:
    """Where the solves run and whether they show progress.

    Attributes
    ----------
    workers : int or None
        Local worker processes (ignored with ``scheduler``); None: one per core this
        process may use (:func:`usable_cores`), resolved on construction.
    scheduler : str or None
        Address of a Dask scheduler (needs ``drivebench[dask]``).
    progress : bool
        Show progress bars.
    workers_reason : str
        Why ``workers`` is what it is: :data:`GIVEN_REASON` or, when it was None,
        :data:`CORES_REASON` (set on construction).
    """

    workers: int | None = None
    scheduler: str | None = None
    progress: bool = False
    workers_reason: str = GIVEN_REASON

    def __post_init__(self) -> None:
        if self.workers is None:
            object.__setattr__(self, "workers", usable_cores())
            object.__setattr__(self, "workers_reason", CORES_REASON)

    def line(self) -> str:
        """The header line of a run: ``"2 workers: the cores this process may use"``
        (or ``"... --workers"``), or the Dask scheduler it runs on."""
        if self.scheduler:
            return f"workers: the Dask cluster at {self.scheduler}"
        plural = "s" if self.workers != 1 else ""
        return f"{self.workers} worker{plural}: {self.workers_reason}"


#: the defaults as objects, for signatures (frozen, so shared safely)
PAPER_GRID = WindGrid()
DEFAULT_SOLVER = SolverChoice()
LOCAL_POOL = Execution()
