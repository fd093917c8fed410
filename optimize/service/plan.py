"""The scenario sweep's plan: continuation order and the start graph.

A sweep is every selected scenario *kind* (objective x drive limits, e.g.
``elec-lim``) at every wind speed of a grid. Solving each of them cold (homotopy)
would be slow, so each solve starts from a solved neighbour; :func:`plan_graph`
plans those starts as a graph, not as chains, so that every core has work.

It runs in two stages. Stage 0 sweeps each objective's *lead* kind
(:func:`lead_kinds`: the one without the drive limits, the relaxation of the
others); its local optima are re-solved before stage 1, in which every other kind
starts at each wind speed from its lead's final optimum there, the drive limits
tightened (a limit switch). A cycle optimization is multimodal: chains of each kind
from their own neighbours land on branches of their own and cost a re-solve each where
those are poor, while a kind started from its settled lead inherits the lead's branch.
On AP2 over 4:14:2 this cut the sweep from 3021 to 1753 IPOPT iterations in all and
made 4 of its optima better (benchmarks/README.md, foreign_kites). Stage 0's graph:

* the *seed* (depth 0) is the sweep's one cold start (the system's stored start where
  it fits, else the homotopy), the first lead kind at the middle wind speed;
* depth 1: the scenarios one step from the seed (:func:`start_cost` at most
  :data:`SEED_STEP_COST`: the seed's kind at the neighbouring wind speeds) and the lead
  of each other objective at the seed's speed (a switch of objective) start from it;
* each further depth: every scenario within :data:`NEAR_START_COST` (a wind step and a
  limit switch) of one planned before starts from the nearest of those;
* every step also lists one fallback source (the next nearest of those); when
  neither converges the solve falls back to a fresh cold start.

So on a grid of up to five wind speeds every lead scenario is at most three solves deep
after the seed, two after the first solve of its objective (stage 1 one more); a longer
grid adds one depth per further wind step each way from the middle, so that no start
jumps farther than one wind step. Farther starts cost iterations and land on
poorer optima: on ``make demo``'s 4:14.5:1.5, depth 2 everywhere started 13 and 14.5 m/s
from 10 m/s, took 1025 IPOPT iterations against 820 for neighbour starts, and found
optima up to 18 W poorer (benchmarks/README.md, sweep_scaling). The steps run on the
solve service (:func:`optimize.service.run.run_sweep`);
the whole ``bench optimize`` command is :func:`optimize.command.run_optimize`.
:func:`chain_steps` still plans the one-kind chains of ``bench size`` and
``bench aep --refine``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from optimize.kinds import KINDS
from optimize.problem.scenario import Scenario


def middle_index(wind_speeds_m_s: tuple[float, ...]) -> int:
    """Index of the middle wind speed (the lower middle for an even count)."""
    return (len(wind_speeds_m_s) - 1) // 2


def continuation_order(wind_speeds_m_s: tuple[float, ...]) -> list[tuple[float, float | None]]:
    """Order the wind speeds outwards from the middle one, alternating above and below.

    Returns
    -------
    list of (wind_speed_m_s, source)
        ``source`` is the inner neighbour [m/s] the solve is warm-started from;
        ``None`` for the middle speed (where a chain starts). For 4:10:1.5:
        ``[(7, None), (8.5, 7), (5.5, 7), (10, 8.5), (4, 5.5)]``.
    """
    mid = middle_index(wind_speeds_m_s)
    order: list[tuple[float, float | None]] = [(wind_speeds_m_s[mid], None)]
    up, down = mid + 1, mid - 1
    while up < len(wind_speeds_m_s) or down >= 0:
        if up < len(wind_speeds_m_s):
            order.append((wind_speeds_m_s[up], wind_speeds_m_s[up - 1]))
            up += 1
        if down >= 0:
            order.append((wind_speeds_m_s[down], wind_speeds_m_s[down + 1]))
            down -= 1
    return order


@dataclass(frozen=True)
class Step:
    """One planned solve.

    Attributes
    ----------
    scenario : Scenario
        The scenario it solves (kind and wind speed at 100 m).
    warm_from : Scenario or None
        The scenario (solved before this one) whose primal and dual solution
        warm-starts this one; ``None`` means a cold start (stored guess or homotopy).
    fallbacks : tuple of Scenario
        Other earlier scenarios to warm-start from, in order, when the primary
        source failed or its solve fails. A cold start is the last resort.
    depth : int
        Planned solves before this one along its starts (0: a cold start).
    stage : int
        The sweep's round the step runs in (:func:`plan_graph`): 0, the lead kinds'
        grid; 1, the other kinds, once the lead kinds' local optima are re-solved.
    """

    scenario: Scenario
    warm_from: Scenario | None
    fallbacks: tuple[Scenario, ...] = ()
    depth: int = 0
    stage: int = 0

    @property
    def name(self) -> str:
        """Scenario name, e.g. ``"elec-lim-7.0"``."""
        return self.scenario.name


def chain_steps(kinds: tuple[str, ...], wind_speeds_m_s: tuple[float, ...]) -> tuple[Step, ...]:
    """The steps of one chain: each kind along :func:`continuation_order`, the next kind
    started at the middle speed from the previous kind's middle solve; every step with up
    to two fallbacks (the nearest solved speeds, the same kind first at equal distance)."""
    order = continuation_order(wind_speeds_m_s)
    mid_wind = order[0][0]
    steps: list[Step] = []
    solved: list[Scenario] = []  # solved earlier in this chain

    def fallbacks(scenario: Scenario, primary: Scenario | None) -> tuple[Scenario, ...]:
        # nearest wind speed first; at equal distance the same kind first
        ranked = sorted(solved, key=lambda s: (abs(s.wind_speed_m_s - scenario.wind_speed_m_s),
                                               s.kind != scenario.kind))
        return tuple(s for s in ranked if s != primary)[:2]

    for i, kind in enumerate(kinds):
        for wind_speed_m_s, source_wind in order:
            scenario = Scenario.of_kind(kind, wind_speed_m_s)
            if source_wind is not None:
                primary = scenario.at(source_wind)
            elif i > 0:
                primary = Scenario.of_kind(kinds[i - 1], mid_wind)
            else:
                primary = None
            steps.append(Step(scenario, primary, fallbacks(scenario, primary), len(steps)))
            solved.append(scenario)
    return tuple(steps)


#: the cost of a start from another kind (:func:`start_cost`), in wind-grid steps: a
#: drive-limit switch within one objective, and a switch of objective
LIMIT_SWITCH_COST, OBJECTIVE_SWITCH_COST = 0.5, 2.0
#: the farthest start (:func:`start_cost`) of a scenario one step from a seed, and of
#: any later one (:func:`plan_graph`); a scenario farther from every planned one waits
#: a depth (unless none is nearer: then the nearest go)
SEED_STEP_COST, NEAR_START_COST = 1.0, 1.5


def start_cost(a: Scenario, b: Scenario, wind_steps: int) -> float:
    """How far apart two scenarios ``wind_steps`` wind-grid steps apart are as warm starts:
    those steps plus :data:`LIMIT_SWITCH_COST` or :data:`OBJECTIVE_SWITCH_COST` when
    their kinds differ."""
    cost = float(wind_steps)
    if a.kind != b.kind:
        cost += LIMIT_SWITCH_COST if a.objective == b.objective else OBJECTIVE_SWITCH_COST
    return cost


def lead_kinds(kinds: tuple[str, ...]) -> tuple[str, ...]:
    """The kind that leads each objective of ``kinds`` (in their order): its first kind
    with the drive limits, else its first. The other kinds of the objective relax the
    lead's limits, so the lead's optimum is a feasible start of theirs."""
    objectives = dict.fromkeys(KINDS[k].objective for k in kinds)
    return tuple(next((k for k in kinds if KINDS[k].objective == obj and not KINDS[k].drive_limits),
                      next(k for k in kinds if KINDS[k].objective == obj))
                 for obj in objectives)


def plan_graph(wind_speeds_m_s: tuple[float, ...], kinds: tuple[str, ...]) -> tuple[Step, ...]:
    """Plan the sweep as a start graph in two stages (see the module docstring).

    Stage 0 is the start graph of the lead kinds (:func:`lead_kinds`). Stage 1 runs once
    the lead kinds' local optima are re-solved: every other kind at each wind speed starts
    from its objective's lead at the same speed (a limit switch: the lead's optimum is
    feasible there), so it starts on the branch the lead's re-solves settled, with the
    lead at the neighbouring speeds as fallbacks.

    Parameters
    ----------
    wind_speeds_m_s : tuple of float
        Wind speeds [m/s], increasing (from :func:`optimize.sweep_options.parse_wind_grid`).
    kinds : tuple of str
        Scenario kinds (from :func:`optimize.sweep_options.parse_kinds`).

    Returns
    -------
    tuple of Step
        Every scenario (kind at a wind speed) exactly once, by stage, then by depth (the
        seed first); each step's sources come before it and are at most ``depth - 1``
        deep; in stage 0 ``depth`` is at most 3 on a grid of up to five wind speeds.
    """
    leads = lead_kinds(kinds)
    graph = _lead_graph(wind_speeds_m_s, tuple(k for k in kinds if k in leads))
    depth = {s.scenario: s.depth for s in graph}
    lead_of = {KINDS[k].objective: k for k in leads}
    derived = []
    for kind in (k for k in kinds if k not in leads):
        lead = lead_of[KINDS[kind].objective]
        for i, w in enumerate(wind_speeds_m_s):
            near = sorted((j for j in (i - 1, i + 1) if 0 <= j < len(wind_speeds_m_s)),
                          key=lambda j: abs(wind_speeds_m_s[j] - w))
            source = Scenario.of_kind(lead, w)
            derived.append(Step(Scenario.of_kind(kind, w), source,
                                tuple(Scenario.of_kind(lead, wind_speeds_m_s[j]) for j in near),
                                depth[source] + 1, stage=1))
    return (*graph, *derived)


def _lead_graph(wind_speeds_m_s: tuple[float, ...], kinds: tuple[str, ...]) -> tuple[Step, ...]:
    """The start graph of stage 0 (:func:`plan_graph`): the module docstring's seed and
    depths."""
    mid_wind = wind_speeds_m_s[middle_index(wind_speeds_m_s)]
    index = {w: i for i, w in enumerate(wind_speeds_m_s)}
    objectives = dict.fromkeys(KINDS[k].objective for k in kinds)
    seed = Scenario.of_kind(kinds[0], mid_wind)
    switches = [Scenario.of_kind(next(k for k in kinds if KINDS[k].objective == obj), mid_wind)
                for obj in objectives if obj != seed.objective]
    rest = [s for s in (Scenario.of_kind(k, w) for k in kinds for w in wind_speeds_m_s)
            if s != seed]

    def cost(a: Scenario, b: Scenario) -> float:
        return start_cost(a, b, abs(index[a.wind_speed_m_s] - index[b.wind_speed_m_s]))

    def step(scenario: Scenario, sources: list[Scenario], depth: int) -> Step:
        ranked = sorted(sources, key=lambda s: cost(scenario, s))[:2]  # stable: plan order
        return Step(scenario, ranked[0] if ranked else None, tuple(ranked[1:]), depth)

    steps = [Step(seed, None)]
    planned, layer = [seed], [seed]
    near = dict.fromkeys(rest, math.inf)  # start cost from the nearest planned scenario
    while rest:
        near = {n: min(near[n], *(cost(n, s) for s in layer)) for n in rest}
        first = planned == [seed]
        limit = max(SEED_STEP_COST if first else NEAR_START_COST, min(near.values()))
        layer = [n for n in rest if near[n] <= limit or (first and n in switches)]
        depth = steps[-1].depth + 1
        steps += [step(n, planned, depth) for n in layer]
        planned += layer
        rest = [n for n in rest if n not in layer]
    return tuple(steps)
