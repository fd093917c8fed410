"""The result check of every converged optimum of a sweep (:mod:`optimize.analysis.result_check`).

Run where the sweep's results are gathered, after the solves: it changes no
optimum, only whether it stands. A scenario that fails the check is a failed
scenario (its ``result_check`` says why), whatever the solver reported.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

from optimize.analysis.result_check import ResultCheck, check_result
from optimize.service.builder import OcpBackend
from optimize.service.outcome import ScenarioOutcome


def check_outcomes(problem: Any, outcomes: Sequence[ScenarioOutcome]
                   ) -> tuple[list[ScenarioOutcome], list[ResultCheck]]:
    """Check every converged outcome; those that fail become failed outcomes.

    Parameters
    ----------
    problem : optimize.service.builder.Problem
        The sweep's problem (its OCP is built here, or taken from the process cache).
    outcomes : sequence of ScenarioOutcome

    Returns
    -------
    (list of ScenarioOutcome, list of ResultCheck)
        The outcomes in order, each converged one carrying its verdict
        (``ScenarioOutcome.check``), and the checks.
    """
    ocp = OcpBackend().build(problem)
    checked, checks = [], []
    for o in outcomes:
        if o.success and o.result is not None:
            c = check_result(ocp, o.result, o.name)
            checks.append(c)
            o = dataclasses.replace(o, check=c.verdict())
        checked.append(o)
    return checked, checks
