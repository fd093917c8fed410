"""Stand-ins of the solve service's backends: the fields of a solve result the service
reads (:class:`optimize.service.builder.SolveResult`), for backends that solve a closed
form instead of the OCP (tests/test_sweep.py, tests/test_period_scan.py)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Result:
    """A solve's status, iterations, wall time [s], electrical power [W] and warm start."""

    status: str
    success: bool
    iterations: int
    wall_time_s: float
    avg_p_elec_w: float
    warm: float
