"""The one solve service: optimal cycles of (system, drive, wind, kind) from warm starts.

Every stage that solves the OCP goes through here: ``bench optimize`` (a start
graph of several kinds, local optima re-solved, cut-in searches), ``bench size``
(a chain per candidate drive, each started from the reference drive's optima, stored
and resumable, optionally refined for the site) and ``bench aep --refine`` (the
speeds where a sweep's curve bends, each started from the nearest solved speed).

=============================================== ==========================================
module                                          concept
=============================================== ==========================================
:mod:`optimize.service.plan`                    the start graph and the warm-start chains
:mod:`optimize.service.executors`               a process pool or Dask, progress channels
:mod:`optimize.service.builder`                 what a worker builds: ``Problem``, backends
:mod:`optimize.service.solves`                  one problem's solves: warm starts, fallbacks,
                                                records, the store
:mod:`optimize.service.foreign`                 starts it did not find itself: another
                                                problem's solution, a stored cycle
:mod:`optimize.service.store`                   solves stored under the hash of their inputs
:mod:`optimize.service.local_optima`            re-solve of scenarios off their kind's curve
:mod:`optimize.service.retry`                   failed scenarios retried from other starts
:mod:`optimize.service.cut_in`                  cut-in bisection
:mod:`optimize.service.chain`                   the one chain loop (``run_chain``)
:mod:`optimize.service.run`                     chains and start graphs on the pool or Dask
:mod:`optimize.service.outcome`                 what it reports; the one failure format
=============================================== ==========================================
"""

from optimize.service.builder import OcpBackend, Problem, problem_key
from optimize.service.chain import ChainTask, Refinement, run_chain
from optimize.service.outcome import failure_status
from optimize.service.run import SolveTask, SweepTasks, run_chains, run_sweep, solve_tasks
from optimize.service.solves import Solves, cycle_metrics
from optimize.service.store import solve_key

__all__ = ["ChainTask", "OcpBackend", "Problem", "Refinement", "SolveTask", "Solves",
           "SweepTasks", "cycle_metrics", "failure_status", "problem_key", "run_chain",
           "run_chains", "run_sweep", "solve_key", "solve_tasks"]
