"""Paper-comparison verdicts on hand-made summary tables (no solver involved).

The "paper-like" table below is written so that every statement of
docs/paper_figures.md §4 holds by construction; each test then breaks one statement
and checks that exactly that verdict changes.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from optimize.analysis.claims import (
    AGREES,
    DIFFERS,
    NOT_COMPARABLE,
    cut_in_frame,
    evaluate_claims,
    format_claims,
)
from optimize.sweep.chains import CutIn

WINDS = (4.0, 5.5, 7.0, 8.5, 10.0)
# average electrical power [W] per kind and wind (negative = generated), paper-like:
# elec beats mech everywhere, largest constrained gain at 5.5, elec lim = free up to 7,
# mech lim = free only at 4, mech-free always consumes.
P_ELEC = {
    "elec-lim": [60.0, -140.0, -560.0, -900.0, -1200.0],
    "elec-free": [60.0, -140.0, -560.0, -1000.0, -1500.0],
    "mech-lim": [150.0, 100.0, -420.0, -850.0, -1150.0],
    "mech-free": [150.0, 120.0, 40.0, 30.0, 20.0],
}
# mechanical power [W]: mech lim = free up to 5.5 only
P_MECH = {
    "elec-lim": [-300.0, -700.0, -1150.0, -1600.0, -2000.0],
    "elec-free": [-300.0, -700.0, -1150.0, -1700.0, -2300.0],
    "mech-lim": [-400.0, -800.0, -1200.0, -1650.0, -2100.0],
    "mech-free": [-400.0, -800.0, -1500.0, -2200.0, -3000.0],
}


def paper_like() -> pd.DataFrame:
    rows = []
    for kind in P_ELEC:
        for i, w in enumerate(WINDS):
            rows.append(
                {
                    "scenario": f"{kind}-{w:.1f}",
                    "kind": kind,
                    "wind_speed_m_s": w,
                    "success": True,
                    "status": "Solve_Succeeded",
                    "avg_p_elec_w": P_ELEC[kind][i],
                    "avg_p_mech_w": P_MECH[kind][i],
                    "period_s": 6.0,
                    "e_elec_j": P_ELEC[kind][i] * 6.0,
                    "peak_speed_rpm": 1500.0,
                    "peak_torque_nm": 60.0,
                    "p_elec_max_w": 3000.0,
                }
            )
    s = pd.DataFrame(rows).set_index("scenario")
    s.loc["elec-lim-5.5", ["period_s", "e_elec_j"]] = [5.9, -827.0]  # Fig. 3
    s.loc["mech-free-10.0", ["period_s", "peak_speed_rpm", "p_elec_max_w"]] = [2.14, 3300, 13000]
    s.loc["elec-free-10.0", ["period_s", "p_elec_max_w"]] = [3.89, 3000.0]
    return s.reset_index()


def cut_ins(mech: float = 5.45, elec: float = 4.85) -> pd.DataFrame:
    return cut_in_frame(
        [
            CutIn("mech-lim", mech, mech - 0.02, mech + 0.02, "found"),
            CutIn("elec-lim", elec, elec - 0.02, elec + 0.02, "found"),
        ]
    )


def verdicts(summary: pd.DataFrame, ci: pd.DataFrame | None = None) -> dict[str, str]:
    table = evaluate_claims(summary, cut_ins() if ci is None else ci)
    assert list(table.columns) == ["claim_id", "statement", "paper", "ours", "verdict", "note"]
    # a note is given exactly where ours is not in agreement
    assert all((r.verdict == AGREES) == (r.note == "") for r in table.itertuples())
    return dict(zip(table["claim_id"], table["verdict"], strict=True))


def test_paper_like_table_agrees_everywhere():
    v = verdicts(paper_like())
    assert len(v) == 15
    assert set(v.values()) == {AGREES}, v


def test_each_broken_statement_flips_only_its_verdict():
    base = verdicts(paper_like())
    cases = {
        # Fig. 3 energy 827 J -> 500 J is 40 % off, beyond the 25 % figure tolerance
        "fig3-energy": ("elec-lim-5.5", "e_elec_j", -500.0),
        "fig3-period": ("elec-lim-5.5", "period_s", 9.0),
        "10ms-mech-period": ("mech-free-10.0", "period_s", 3.0),
        "10ms-mech-peak-rpm": ("mech-free-10.0", "peak_speed_rpm", 2000.0),
        # mech-free generating at 8.5 m/s breaks "consumes at every speed"
        "mech-free-consumes": ("mech-free-8.5", "avg_p_elec_w", -10.0),
        # mech-free equal to mech-lim in P_mech at 7 m/s: limits not active there
        "mech-lim-eq-free-mech": ("mech-free-7.0", "avg_p_mech_w", -1200.0),
        # elec-free differing from elec-lim at 5.5 m/s by 50 W (> 1 % and > 5 W)
        "elec-lim-eq-free": ("elec-free-5.5", "avg_p_elec_w", -190.0),
    }
    for claim, (scenario, column, value) in cases.items():
        s = paper_like().set_index("scenario")
        s.loc[scenario, column] = value
        v = verdicts(s.reset_index())
        changed = {k for k in v if v[k] != base[k]}
        assert changed == {claim}, (claim, changed)
        assert v[claim] == DIFFERS


def test_ordering_and_gain_peak():
    s = paper_like().set_index("scenario")
    # mech-lim beats elec-lim by 20 W at 7 m/s: the ordering claim fails, 1 W noise allowed
    s.loc["mech-lim-7.0", "avg_p_elec_w"] = -580.0
    v = verdicts(s.reset_index())
    assert v["elec-beats-mech"] == DIFFERS
    s.loc["mech-lim-7.0", "avg_p_elec_w"] = -560.5  # within ORDER_ATOL_W = 1 W
    assert verdicts(s.reset_index())["elec-beats-mech"] == AGREES
    # largest gain moved to 8.5 m/s
    s.loc["mech-lim-8.5", "avg_p_elec_w"] = -300.0
    assert verdicts(s.reset_index())["gain-peak-5.5"] == DIFFERS


def test_coincidence_tolerance_is_one_percent_or_five_watts():
    s = paper_like().set_index("scenario")
    s.loc["elec-free-7.0", "avg_p_elec_w"] = -560.0 - 5.5  # 1 % of 565.5 W is 5.7 W
    assert verdicts(s.reset_index())["elec-lim-eq-free"] == AGREES
    s.loc["elec-free-7.0", "avg_p_elec_w"] = -560.0 - 6.0  # 6 W > 5.66 W
    s.loc["elec-lim-7.0", "peak_torque_nm"] = 77.8  # within 0.5 % of the 78 N m limit
    table = evaluate_claims(s.reset_index(), cut_ins()).set_index("claim_id")
    assert table.loc["elec-lim-eq-free", "verdict"] == DIFFERS
    # the note names the wind speed and the limit that is active there
    note = table.loc["elec-lim-eq-free", "note"]
    assert "at 7 m/s lim -560 W vs free -566 W" in note and "torque 77.8 N m" in note
    s.loc["elec-free-7.0", "avg_p_elec_w"] = -560.0
    # mech: P_mech still equal at 7 m/s contradicts "coincide up to 5.5 m/s only"
    s.loc["mech-free-7.0", "avg_p_mech_w"] = -1200.0
    assert verdicts(s.reset_index())["mech-lim-eq-free-mech"] == DIFFERS


def test_cut_in_verdicts():
    v = verdicts(paper_like(), cut_ins(mech=6.2, elec=4.85))  # 0.7 m/s > 0.5 m/s tolerance
    assert v["cut-in-mech-lim"] == DIFFERS and v["cut-in-elec-lim"] == AGREES
    v = verdicts(paper_like(), cut_ins(mech=5.0, elec=5.2))
    assert v["cut-in-order"] == DIFFERS
    none = cut_in_frame(
        [
            CutIn("mech-lim", math.nan, 10.0, math.nan, "never generates on the grid"),
            CutIn("elec-lim", math.nan, math.nan, math.nan, "probe failed at 4.75 m/s"),
        ]
    )
    table = evaluate_claims(paper_like(), none).set_index("claim_id")
    assert table.loc["cut-in-mech-lim", "verdict"] == NOT_COMPARABLE
    assert "above 10 m/s" in table.loc["cut-in-mech-lim", "ours"]
    assert table.loc["cut-in-elec-lim", "verdict"] == NOT_COMPARABLE
    assert table.loc["cut-in-order", "verdict"] == NOT_COMPARABLE


def test_failed_and_missing_scenarios_are_not_comparable():
    s = paper_like().set_index("scenario")
    s.loc["elec-lim-5.5", ["success", "status"]] = [False, "Infeasible_Problem_Detected"]
    s.loc["elec-lim-5.5", ["period_s", "e_elec_j", "avg_p_elec_w"]] = np.nan
    s = s.reset_index()
    s = s[s["kind"] != "mech-free"]
    table = evaluate_claims(s, cut_in_frame([])).set_index("claim_id")
    for cid in (
        "fig3-period",
        "fig3-energy",
        "mech-free-consumes",
        "10ms-mech-period",
        "cut-in-mech-lim",
        "mech-lim-eq-free-elec",
    ):
        assert table.loc[cid, "verdict"] == NOT_COMPARABLE, cid
        assert "missing" in table.loc[cid, "note"]
    # the failed 5.5 m/s row is left out of the ordering check, not counted as a pass or fail
    assert table.loc["elec-beats-mech", "ours"] == "holds at 4/4 pairs"
    text = format_claims(table.reset_index())
    assert text.splitlines()[-1].endswith("not comparable")
    assert "fig3-energy" in text


@pytest.mark.parametrize(
    "gap_w, verdict", [(10000.0, AGREES), (12400.0, AGREES), (13000.0, DIFFERS)]
)
def test_peak_power_gap_tolerance(gap_w, verdict):
    s = paper_like().set_index("scenario")
    s.loc["mech-free-10.0", "p_elec_max_w"] = 3000.0 + gap_w
    assert verdicts(s.reset_index())["10ms-peak-p-elec-gap"] == verdict
