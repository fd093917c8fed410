"""Whether a sizing's choice is a decision for the site: what its wind grid covers.

The sizing AEP of every candidate counts the wind between the grid's first and last speed
only (linear in between, zero outside). Above the grid that leaves out energy the
candidates would deliver, and more of it for the larger ones; below the grid only when a
candidate already delivers at its first speed (below a cut-in inside the grid nothing is
lost). What a grid leaves out is measured in the site's available wind energy
(``rho v^3 / 2`` over the year, :func:`energy.site.energy_share`): a choice made on a grid
that leaves out more than :data:`energy.site.ENERGY_LEFT_OUT` of it is not a decision, and
:func:`decision` says what it rests on, how much each candidate's AEP could still grow in
the hours left out (:func:`headroom_mwh`: at most its torque limit times its speed limit,
the largest shaft power its limits let a cycle deliver, and the electrical power
delivered is below the shaft's), and the grid that covers the site
(:func:`covering_sizing_grid`, the default of ``bench size``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from energy.site import (
    ENERGY_LEFT_OUT,
    HOURS_PER_YEAR,
    Distribution,
    covering_stop,
    energy_quantile,
    energy_share,
)

#: the first speed and the step [m/s] of the sizing grid that covers the site: bench
#: optimize's default grid starts at 4 m/s in 1.5 m/s steps; sizing solves twice the step
SIZING_GRID_START_M_S, SIZING_GRID_STEP_M_S = 4.0, 3.0
#: the cut-out of the wind range the solves accept [m/s] (optimize.sweep_options.WIND_RANGE_M_S)
CUT_OUT_M_S = 25.0
#: below a grid's first speed at most this share of the wind energy may lie where a
#: candidate already delivers there (:func:`wider_grid`)
BELOW_SHARE = 0.005


def covering_sizing_grid(site: Distribution, start_m_s: float = SIZING_GRID_START_M_S,
                         step_m_s: float = SIZING_GRID_STEP_M_S) -> tuple[float, ...]:
    """The sizing grid that covers ``site``: from ``start_m_s`` in steps of ``step_m_s`` up
    to the first speed below which ``1 -`` :data:`energy.site.ENERGY_LEFT_OUT` of the
    site's available wind energy lies (:func:`energy.site.covering_stop`), at most the
    cut-out [m/s]."""
    stop = covering_stop(site, start_m_s, step_m_s, ceiling_m_s=CUT_OUT_M_S)
    n = round((stop - start_m_s) / step_m_s)
    return tuple(round(start_m_s + i * step_m_s, 6) for i in range(n + 1))


def grid_spec(speeds: tuple[float, ...]) -> str:
    """``START:STOP:STEP`` of an evenly spaced grid, else the comma list."""
    s = [float(x) for x in speeds]
    steps = np.diff(s)
    if len(s) > 2 and np.allclose(steps, steps[0]):
        return f"{s[0]:g}:{s[-1]:g}:{steps[0]:g}"
    return ",".join(f"{x:g}" for x in s)


def grid_coverage(site: Distribution, wind_speeds_m_s: tuple[float, ...],
                  records: list[dict] | tuple = ()) -> dict:
    """What a sizing grid covers of ``site``: the hours and the available wind energy below
    its first and above its last speed, the candidates that already deliver at its first
    speed (``records``: the solves, :attr:`energy.sizing.SizingResult.records`), and the
    share of each the grid leaves out (above it, and below it where a candidate delivers
    at its first speed), with a one-line note.

    Returns
    -------
    dict
        ``grid_m_s`` ([first, last]), ``share_below_grid``, ``share_above_grid``,
        ``share_left_out`` (hours), ``energy_below_grid``, ``energy_above_grid``,
        ``energy_left_out`` (the site's available wind energy), ``deliver_at_first``
        (candidate names), ``note``.
    """
    lo, hi = min(wind_speeds_m_s), max(wind_speeds_m_s)
    below, above = float(site.cdf(lo)), float(1.0 - site.cdf(hi))
    e_below, e_above = energy_share(site, 0.0, lo), energy_share(site, hi)
    first = [r for r in records if r.get("success") and abs(r["wind_speed_m_s"] - lo) < 1e-9]
    delivering = sorted({str(r["candidate"]) for r in first if r["avg_p_elec_w"] < 0})
    counts_below = bool(delivering) or not first
    left = above + (below if counts_below else 0.0)
    e_left = e_above + (e_below if counts_below else 0.0)
    where = (f"{_pct(below)} of the hours ({_pct(e_below)} of the wind energy) below it and "
             f"{_pct(above)} ({_pct(e_above)}) above it count as zero power" if counts_below
             else f"{_pct(above)} of the hours ({_pct(e_above)} of the wind energy) above it "
                  f"count as zero power; below {lo:g} m/s no candidate delivers")
    note = (f"the sizing grid {lo:g}-{hi:g} m/s covers {_pct(1 - e_left)} of the site's wind "
            f"energy ({_pct(1 - left)} of its hours); {where}")
    return {"grid_m_s": [lo, hi], "share_below_grid": below, "share_above_grid": above,
            "share_left_out": left, "energy_below_grid": e_below,
            "energy_above_grid": e_above, "energy_left_out": e_left,
            "deliver_at_first": delivering, "note": note}


def headroom_mwh(candidate: dict, coverage: dict) -> float:
    """The most a candidate's AEP could grow in the hours a grid leaves out [MWh/yr]: its
    torque limit times its speed limit (the largest shaft power a cycle within its limits
    can deliver; the electrical power delivered is less by the losses) over those hours."""
    cap_w = float(candidate["peak_torque_nm"]) * float(candidate["max_speed_rpm"]) * math.pi / 30
    return cap_w * coverage["share_left_out"] * HOURS_PER_YEAR / 1e6


def wider_grid(site: Distribution, coverage: dict) -> tuple[float, ...]:
    """A grid in the default sizing step that covers the site: from the default start, or,
    where a candidate delivers at a grid's first speed at or below it, one step lower (not
    below the speed under which :data:`BELOW_SHARE` of the wind energy lies), to the
    covering stop."""
    start, lo = SIZING_GRID_START_M_S, coverage["grid_m_s"][0]
    if coverage["deliver_at_first"] and lo <= start:
        start = max(round(energy_quantile(site, BELOW_SHARE), 1), lo - SIZING_GRID_STEP_M_S)
    return covering_sizing_grid(site, start)


def _choice(aeps: dict[str, float], torques: dict[str, float],
            tolerance: float) -> tuple[str, str]:
    """The best and the smallest within ``tolerance`` of it, by AEP and rated torque."""
    best = max(aeps, key=aeps.get)
    within = [c for c in aeps if aeps[c] >= (1 - tolerance) * aeps[best]]
    return best, min(within, key=lambda c: torques[c])


def decision(table: Any, records: list[dict], site: Distribution, coverage: dict,
             tolerance: float) -> dict:
    """Whether the sizing's choice holds for the site, and why (see the module text).

    Parameters
    ----------
    table : pandas.DataFrame
        :func:`energy.sizing.candidate_table`'s rows.
    records : list of dict
        Every solve.
    site : Weibull or Histogram
    coverage : dict
        :func:`grid_coverage` of the grid.
    tolerance : float
        The choice is the smallest within this share of the best AEP.

    Returns
    -------
    dict
        ``holds`` (bool), ``limit`` (:data:`energy.site.ENERGY_LEFT_OUT`), ``chosen``,
        ``best``, ``next_smaller`` (the candidate below the chosen in rated torque with
        its AEP, or None), ``headroom_mwh`` (candidate -> :func:`headroom_mwh`),
        ``covering_grid`` (``START:STOP:STEP`` that covers the site), ``line`` (for the
        console and the report).
    """
    valid = table[table["aep_elec_mwh"].fillna(0.0) > 0].sort_values("rated_torque_nm",
                                                                      kind="stable")
    if valid.empty:  # none got an AEP, or none delivers energy: nothing to choose
        return {"holds": False, "limit": ENERGY_LEFT_OUT, "chosen": None, "best": None,
                "next_smaller": None, "headroom_mwh": {}, "covering_grid": None,
                "line": "no candidate got an AEP above 0: no decision"}
    aeps = dict(zip(valid["candidate"], valid["aep_elec_mwh"].astype(float), strict=True))
    torques = dict(zip(valid["candidate"], valid["rated_torque_nm"].astype(float), strict=True))
    best, chosen = _choice(aeps, torques, tolerance)
    lo, hi = coverage["grid_m_s"]
    room = {r["candidate"]: headroom_mwh(r, coverage) for r in valid.to_dict(orient="records")}
    order = list(valid["candidate"])
    smaller = order[order.index(chosen) - 1] if order.index(chosen) > 0 else None
    holds = coverage["energy_left_out"] <= ENERGY_LEFT_OUT + 1e-12
    wider = grid_spec(wider_grid(site, coverage))
    rule = f"the smallest within {tolerance:.0%} of the best AEP"
    if holds:
        line = (f"chosen: {chosen} ({rule}; best {best}), on a grid that covers "
                f"{_pct(1 - coverage['energy_left_out'])} of the site's wind energy")
    else:
        line = (f"not a decision: on the grid {lo:g}-{hi:g} m/s {rule} is {chosen} (best "
                f"{best}), but the grid leaves out {_pct(coverage['energy_left_out'])} of the "
                f"site's wind energy (more than {_pct(ENERGY_LEFT_OUT)}): in those hours a "
                f"candidate's AEP could still grow by up to {min(room.values()):.3g} to "
                f"{max(room.values()):.3g} MWh/yr (its torque limit times its speed limit), "
                f"against {min(aeps.values()):.3g} to {max(aeps.values()):.3g} MWh/yr on the "
                f"grid; size on a grid that covers the site: --wind-grid {wider} (bench "
                "size's default)")
    return {"holds": holds, "limit": ENERGY_LEFT_OUT, "chosen": chosen, "best": best,
            "next_smaller": (None if smaller is None else
                             {"candidate": smaller, "aep_elec_mwh": aeps[smaller]}),
            "headroom_mwh": room, "covering_grid": wider, "line": line}


def _pct(share: float) -> str:
    return f"{100 * share:.1f} %"
