"""optimize's front door: all that the other stages (energy, cycle, reports, the API and
the command line) use of it, besides the sweep folder's readers
(:mod:`optimize.sweep_folder`). ``tests/test_layers.py`` holds them to it.

Each name is imported from its home module on first use (:mod:`kernel.lazy`), so a stage
that imports the door at the top loads the solver only when it solves.

======================================= ==========================================================
home module                             what the other stages use
======================================= ==========================================================
:mod:`optimize.kinds`                   the scenario kinds and their objectives
:mod:`optimize.cycles`                  a cycle: its quadrature, figures, closed form, plot
:mod:`optimize.plots`                   the figures of cycles (and of the map they run on)
:mod:`optimize.sweep_options`           a sweep's grouped options; the wind grid's parser, its range
:mod:`optimize.resolve`                 the one resolution of system, drive and OCP options
:mod:`optimize.command`                 ``bench optimize`` as a library call
:mod:`optimize.cli`                     its exit codes, ``--call-time-limit``
:mod:`optimize.problem.deadline`        the default wall-time limit of a solver call
:mod:`optimize.service`                 the one solve service: problems, chains, their records
:mod:`optimize.service.foreign`         starts it did not find itself (a sweep's stored cycles)
:mod:`optimize.service.store`           the stored solves it did not believe, in words
:mod:`optimize.problem.options`         the OCP's options; :mod:`~optimize.problem.scenario` cases
:mod:`optimize.system.system_file`      system files (and a manifest's system record)
:mod:`optimize.system.contradictions`   every check of a drive in a system before any solve
:mod:`optimize.model.drivetrain`        the similarity law that carries a drive's losses
:mod:`optimize.model.envelope`          the drive's torque-speed envelope as a curve
:mod:`optimize.paper_model`             the paper's drive model
======================================= ==========================================================
"""

from kernel.lazy import lazy_names

#: home module -> the names the other stages use of it
LAZY_IMPORTS = {
    "optimize.kinds": ("KINDS", "LABELS", "OBJECTIVES", "kind_of"),
    "optimize.cycles": ("Cycle", "closed_cycle", "cycle_metrics", "cycle_quadrature",
                        "sweep_cycles"),
    "optimize.plots": ("MARKER_STEP_S", "SCENARIO_COLORS", "equal_time_samples", "plot_cycle",
                       "plot_efficiency_map"),
    "optimize.sweep_options": ("DEFAULT_SOLVER", "LOCAL_POOL", "PAPER_GRID", "PAPER_WINDS_M_S",
                               "WIND_RANGE_M_S", "Execution", "SolverChoice", "WindGrid",
                               "parse_wind_grid"),
    "optimize.resolve": ("Setup", "resolve"),
    "optimize.command": ("OptimizeOutcome", "SweepRequest", "make_request", "run_optimize"),
    "optimize.cli": ("EXIT_SOME_FAILED", "add_call_time_limit", "check_call_time_limit"),
    "optimize.problem.deadline": ("CALL_WALL_LIMIT_S",),
    "optimize.service": ("ChainTask", "Problem", "Refinement", "SolveTask", "run_chain",
                         "run_chains", "solve_tasks"),
    "optimize.service.solves": ("attempt_line",),
    "optimize.service.foreign": ("CycleStart",),
    "optimize.service.outcome": ("failure_reason", "transient"),
    "optimize.service.executors": ("open_executor",),
    "optimize.service.store": ("rejected_lines",),
    "optimize.problem.options": ("Discretization", "OcpOptions", "SolverOptions"),
    "optimize.problem.scenario": ("Scenario", "scenario_name"),
    "optimize.system.system_file": ("load_system", "system_from_dict"),
    "optimize.system.contradictions": ("check_drive",),
    "optimize.model.drivetrain": ("carry_power_model",),
    "optimize.model.envelope": ("envelope_curve",),
    "optimize.paper_model": ("paper_model",),
}

__all__ = sorted(name for names in LAZY_IMPORTS.values() for name in names)
__getattr__, __dir__ = lazy_names(__name__, LAZY_IMPORTS)
