"""The options of a sweep, grouped: which scenarios (:class:`WindGrid`, with the parsers
of ``--wind-grid`` and ``--scenarios``), how each is discretized and solved
(:class:`SolverChoice`), where the solves run (:class:`Execution`).

``bench optimize``, ``bench aep --refine``, ``bench size`` and the Python API
(docs/python_api.md) build the same objects: the command line from its options
(:meth:`WindGrid.parse`), a Python caller directly.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

from kernel.errors import InputError
from optimize.kinds import KINDS
from optimize.problem.deadline import CALL_WALL_LIMIT_S

#: ``--wind-grid``'s default (:func:`parse_wind_grid`)
DEFAULT_WIND_GRID = "4:10:1.5"
#: a generous bound on the number of wind speeds (each is one solve per kind)
MAX_WIND_SPEEDS = 200
#: a sweep by a solver other than IPOPT is given up once this many of its scenarios failed
#: and none converged (:class:`optimize.service.run.GaveUp`; the command then names
#: --solver ipopt): the seed's cold start and the two cold starts after it on two workers
GIVE_UP_AFTER = 3
#: plausible wind speeds at 100 m [m/s], checked before any solve: from a light air in
#: which no kite flies to the 25 m/s cut-out wind of IEC 61400-1 that ends wind-energy
#: operation (the paper sweeps 4 to 10 m/s); a speed outside is a typo
#: (200 for 20) that would cost minutes of failing solves
WIND_RANGE_M_S = (1.0, 25.0)


def _bad_grid(spec: str, problem: str) -> InputError:
    return InputError(
        None,
        f"--wind-grid {spec!r}: {problem}",
        expected="START:STOP:STEP (endpoints included, e.g. 4:10:1.5), "
        "a comma list (4,5.5,7) or one speed, in m/s, all > 0",
    )


def _number(spec: str, text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise _bad_grid(spec, f"{text.strip()!r} is not a number") from None
    if not math.isfinite(value):
        raise _bad_grid(spec, f"{text.strip()!r} is not finite")
    return value


def parse_wind_grid(spec: str) -> tuple[float, ...]:
    """Parse a wind grid specification into sorted wind speeds [m/s].

    Parameters
    ----------
    spec : str
        ``START:STOP:STEP`` with both endpoints included (``4:10:1.5`` ->
        4, 5.5, 7, 8.5, 10); ``STOP - START`` must be a whole multiple of
        ``STEP``. Or a comma-separated list (``4,5.5,7``), or one speed.

    Returns
    -------
    tuple of float
        Strictly increasing wind speeds at 100 m altitude [m/s].

    Raises
    ------
    InputError
        On anything else: non-numbers, speeds <= 0 or outside
        :data:`WIND_RANGE_M_S`, a step <= 0, a stop below the start, a stop that
        is not on the grid, duplicates, or more than :data:`MAX_WIND_SPEEDS` speeds.
    """
    text = spec.strip()
    if not text:
        raise _bad_grid(spec, "empty")
    if ":" in text:
        parts = text.split(":")
        if len(parts) != 3:
            raise _bad_grid(spec, f"{len(parts)} fields separated by ':'")
        start, stop, step = (_number(spec, p) for p in parts)
        if step <= 0:
            raise _bad_grid(spec, f"step {step:g} is not > 0")
        if stop < start:
            raise _bad_grid(spec, f"stop {stop:g} is below start {start:g}")
        n_steps = (stop - start) / step
        if n_steps + 1 > MAX_WIND_SPEEDS:
            raise _bad_grid(spec, f"{math.floor(n_steps) + 1} speeds, more than {MAX_WIND_SPEEDS}")
        n_whole = round(n_steps)
        if abs(n_steps - n_whole) > 1e-9 * max(1.0, n_steps):
            raise _bad_grid(
                spec, f"stop {stop:g} is not start {start:g} plus a whole number of steps {step:g}"
            )
        wind_speeds_m_s = [round(start + i * step, 9) for i in range(n_whole + 1)]
        wind_speeds_m_s[-1] = stop
    else:
        wind_speeds_m_s = [_number(spec, p) for p in text.split(",")]
        if len(wind_speeds_m_s) > MAX_WIND_SPEEDS:
            raise _bad_grid(spec, f"{len(wind_speeds_m_s)} speeds, more than {MAX_WIND_SPEEDS}")
    bad = [w for w in wind_speeds_m_s if w <= 0]
    if bad:
        raise _bad_grid(spec, f"wind speed {bad[0]:g} is not > 0")
    lo, hi = WIND_RANGE_M_S
    bad = [w for w in wind_speeds_m_s if not lo <= w <= hi]
    if bad:
        raise _bad_grid(spec, f"wind speed {bad[0]:g} m/s is outside the plausible "
                              f"{lo:g} to {hi:g} m/s")
    ordered = sorted(wind_speeds_m_s)
    dupes = [a for a, b in zip(ordered, ordered[1:], strict=False) if a == b]
    if dupes:
        raise _bad_grid(spec, f"wind speed {dupes[0]:g} appears twice")
    return tuple(ordered)


def parse_kinds(spec: str) -> tuple[str, ...]:
    """Parse ``--scenarios`` (comma list of kinds of :data:`KINDS`) into kinds, in given order.

    Raises
    ------
    InputError
        On an unknown or repeated kind, or an empty list.
    """
    kinds = tuple(k.strip() for k in spec.split(",") if k.strip())
    expected = "a comma list of " + ", ".join(KINDS)
    if not kinds:
        raise InputError(None, f"--scenarios {spec!r}: no scenario kind given", expected=expected)
    for k in kinds:
        if k not in KINDS:
            raise InputError(None, f"--scenarios {spec!r}: unknown kind {k!r}", expected=expected)
    if len(set(kinds)) != len(kinds):
        raise InputError(None, f"--scenarios {spec!r}: a kind appears twice", expected=expected)
    return kinds


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
        """The grid of ``--wind-grid`` and ``--scenarios`` (:func:`parse_wind_grid`,
        :func:`parse_kinds`)."""
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
