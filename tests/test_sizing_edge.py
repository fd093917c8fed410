"""Sizing says when its best drive is at the edge of the candidate set, extends the set,
(what its wind grid leaves out: tests/test_sizing_decision.py)."""

from __future__ import annotations

import pytest

from energy import sizing, sizing_files
from energy.site import Weibull
from energy.sizing import (
    candidate_table,
    edge_of_set,
    next_scale,
    scaled_candidates,
    size_extending,
)
from optimize.paper_model import paper_model
from optimize.system.drive_in_force import drive_in_force
from optimize.system.system_file import load_system

SITE = Weibull(2.0, 6.2)


def _candidates(scales):
    system = load_system()
    rating = drive_in_force(system, drive_model=paper_model())[0].rating_part()
    return scaled_candidates(rating.with_losses(paper_model()), scales)


def _records(cands, power_of_scale, winds=(5.0, 9.0)):
    """Made-up converged solves: the same delivered power at every wind speed."""
    return [{"candidate": c.name, "wind_speed_m_s": w, "success": True,
             "avg_p_elec_w": -power_of_scale(c.scale), "rms_torque_nm": 1.0}
            for c in cands for w in winds]


@pytest.mark.parametrize(("power", "edge"), [
    (lambda s: 100.0 * s, "largest"),             # AEP grows with the drive
    (lambda s: 100.0 / s, "smallest"),            # AEP falls with the drive
    (lambda s: 100.0 - (s - 1.0) ** 2, None),     # the best, x1, lies inside
])
def test_edge_of_set_names_the_end_the_best_drive_sits_at(power, edge):
    cands = _candidates((0.5, 1.0, 2.0))
    table, best, _ = candidate_table(cands, _records(cands, power), SITE)
    assert edge_of_set(table, best) == edge


def test_a_candidate_without_aep_does_not_hide_the_edge():
    # x2 failed a solve (no AEP): x1 is then the largest drive with an AEP, and the best
    cands = _candidates((0.5, 1.0, 2.0))
    recs = _records(cands, lambda s: 100.0 * s)
    recs[-1] = {**recs[-1], "success": False, "avg_p_elec_w": None}
    table, best, _ = candidate_table(cands, recs, SITE)
    assert (best, edge_of_set(table, best)) == ("x1", "largest")


def test_next_scale_continues_the_outer_ratio():
    assert next_scale((0.5, 0.75, 1.0, 1.5, 2.0), "largest") == pytest.approx(2.67)
    assert next_scale((0.5, 0.75, 1.0, 1.5, 2.0), "smallest") == pytest.approx(0.333)
    assert next_scale((1.0,), "largest") == 2.0 and next_scale((1.0,), "smallest") == 0.5


def _fake_sizing(power):
    """run_sizing without solves: made-up powers by scale, the real choice rule; a
    candidate seen before is "loaded from the store", as the real store does."""
    seen: set[str] = set()

    def run(cands, winds=(5.0, 9.0)):
        table, best, chosen = candidate_table(cands, _records(cands, power, winds), SITE)
        new = [c.name for c in cands if c.name not in seen]
        seen.update(new)
        return sizing.SizingResult(table, [], best, chosen, 1.0, "none",
                                   len(new) * len(winds), (len(cands) - len(new)) * len(winds))
    return run


@pytest.mark.parametrize(("extend", "added", "edge"), [(0, [], "largest"), (1, [4.0], None)])
def test_sizing_extends_the_set_beyond_an_edge_optimum(extend, added, edge):
    # delivered power peaks at scale 2.5: x2 is best of 0.5, 1, 2 (the largest); with one
    # extension x4 (2 x 2/1) is tried, x2 stays best and now lies inside the set
    res, got_edge, got_added = size_extending(
        _candidates, (0.5, 1.0, 2.0), extend, _fake_sizing(lambda s: 1000.0 - (s - 2.5) ** 2))
    assert (res.best, got_edge, got_added) == ("x2", edge, added)
    # every solve counted once over the rounds: (3 + added) candidates x 2 speeds, none
    # loaded from an earlier run; one second per round
    assert (res.n_solved, res.n_cached, res.wall_time_s) == (2 * (3 + len(added)), 0,
                                                             1.0 + len(added))
    note = sizing_files.edge_note(got_edge, res.best, got_added)
    assert ("larger drive may be better" in note) == (edge == "largest")
