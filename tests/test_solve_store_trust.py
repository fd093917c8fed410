"""Nothing stored is believed unchecked: a poisoned, truncated, foreign or inconsistent
stored solve is named (file and why) and solved again (optimize/service/store.py), and a
sizing whose solves crashed never replaces a better one already written
(energy/size_command.py)."""

from __future__ import annotations

import json
import os
import shutil
from concurrent.futures import ThreadPoolExecutor
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from energy.site import Weibull
from energy.sizing import run_sizing, scaled_candidates
from optimize.paper_model import paper_model
from optimize.problem.scenario import Scenario
from optimize.service.executors import ExecutorHandle, QueueChannel
from optimize.service.store import read_solve, rejected_lines, store_solve
from optimize.solve.result import Solution
from optimize.system.drive_in_force import drive_in_force
from optimize.system.system_file import load_system

RATING = drive_in_force(load_system(), drive_model=paper_model())[0].rating_part()
SITE, WINDS = Weibull(2.0, 6.2), (6.0, 7.0)


class LinearBackend:
    """A stand-in OCP whose optimum is known: P_elec = -100 W x wind x torque scale; it
    counts its solves (a loaded solve is not one)."""

    def __init__(self):
        self.solves = 0

    def build(self, problem):
        return problem.system.drive.max_torque_nm / 78.0

    def _result(self, scale, wind):
        self.solves += 1
        traj = pd.DataFrame({"weight": [0.5, 0.5], "speed_rpm": [-900.0, 300.0],
                             "torque_nm": [30.0, 30.0]})
        return SimpleNamespace(success=True, status="Solve_Succeeded", start="stored guess",
                               iterations=5, wall_time_s=1e-3,
                               avg_p_elec_w=-100.0 * wind * scale, avg_p_mech_w=-150.0 * wind,
                               period_s=8.0, trajectory=traj,
                               warm=Solution(np.full(4, wind), np.zeros(4), np.zeros(2), 1, 1))

    def solve(self, ocp, scenario, warm):
        wind = scenario.wind_speed_m_s
        return self._result(ocp, wind)

    def cold_start(self, ocp, scenario):
        wind = scenario.wind_speed_m_s
        return self._result(ocp, wind)

    def check(self, ocp, result, name):
        return None


def _size(tmp_path, backend):
    cands = scaled_candidates(RATING.with_losses(paper_model()), (1.0, 2.0))
    handle = ExecutorHandle(ThreadPoolExecutor(1), QueueChannel(), "1 thread", 1)
    return run_sizing(cands, WINDS, SITE, tmp_path, n_intervals=10, handle=handle,
                      show_progress=False, backend=backend)


def _truth(candidate: str, wind: float) -> float:
    return -100.0 * wind * {"x1": 1.0, "x2": 2.0}[candidate]


def _file(tmp_path, res, candidate, wind, ext="json"):
    rec = next(r for r in res.records if (r["candidate"], r["wind_speed_m_s"]) == (candidate, wind))
    return tmp_path / "solves" / f"{rec['key']}.{ext}"


def _edit_json(path, change):
    doc = json.loads(path.read_text())
    change(doc)
    path.write_text(json.dumps(doc))


DAMAGE = {
    # the three: a figure tripled, a .npz cut to 200 bytes, success flipped
    "power tripled": (lambda p, q: _edit_json(p, lambda d: d.update(
        avg_p_elec_w=3 * d["avg_p_elec_w"])), "its content differs from the SHA-256 it records"),
    "npz truncated": (lambda p, q: q.write_bytes(q.read_bytes()[:200]),
                      "not the warm start its record lists (200 bytes"),
    "success flipped": (lambda p, q: _edit_json(p, lambda d: d.update(success=False)),
                        "its content differs from the SHA-256 it records"),
    # and more of their class
    "record truncated": (lambda p, q: p.write_bytes(p.read_bytes()[:100]), "unreadable"),
    "record empty": (lambda p, q: p.write_bytes(b""), "unreadable"),
    "not JSON": (lambda p, q: p.write_bytes(b"\xff\xfe garbage"), "unreadable"),
    "a JSON list": (lambda p, q: p.write_text("[1, 2]"), "records no content hash"),
    "hash block removed": (lambda p, q: _edit_json(p, lambda d: d.pop("store")),
                           "records no content hash"),
    "another format": (lambda p, q: _edit_json(p, lambda d: d["store"].update(format=1)),
                       "stored in format 1"),
    "npz removed": (lambda p, q: q.unlink(), "not the warm start its record lists (missing)"),
    "npz bytes flipped": (lambda p, q: q.write_bytes(q.read_bytes()[:-9] + b"123456789"),
                          "content differs from the recorded SHA-256"),
    "record is a FIFO": (lambda p, q: (p.unlink(), os.mkfifo(p)), "not a regular file"),
}


@pytest.mark.parametrize("case", sorted(DAMAGE))
def test_a_damaged_stored_solve_is_named_and_solved_again(tmp_path, case):
    first = _size(tmp_path, LinearBackend())
    assert first.n_solved == 4 and all(r["success"] for r in first.records)
    js, npz = _file(tmp_path, first, "x2", 7.0), _file(tmp_path, first, "x2", 7.0, "npz")
    damage, why = DAMAGE[case]
    damage(js, npz)
    backend = LinearBackend()
    again = _size(tmp_path, backend)
    redone = next(r for r in again.records if (r["candidate"], r["wind_speed_m_s"]) == ("x2", 7.0))
    assert not redone["cached"] and redone["success"]
    assert redone["avg_p_elec_w"] == pytest.approx(_truth("x2", 7.0))
    assert redone["store_rejected"].startswith(str(npz if "npz" in case else js) + ": ")
    assert why in redone["store_rejected"], redone["store_rejected"]
    # the other three are loaded, the damaged one solved again: nothing else changed
    assert (again.n_solved, again.n_cached, backend.solves) == (1, 3, 1)
    for r in again.records:
        assert r["avg_p_elec_w"] == pytest.approx(_truth(r["candidate"], r["wind_speed_m_s"]))
    np.testing.assert_allclose(again.table["aep_elec_mwh"], first.table["aep_elec_mwh"])
    (line,) = rejected_lines(again.records)
    assert line.endswith("; x2 elec-lim 7 m/s solved again") and why in line
    # stored again, whole: a third run loads it
    third = _size(tmp_path, LinearBackend())
    assert (third.n_solved, third.n_cached) == (0, 4)
    assert not rejected_lines(third.records)


def test_a_stored_solve_of_another_problem_or_speed_is_not_taken(tmp_path):
    first = _size(tmp_path, LinearBackend())
    x1_7, x2_7 = _file(tmp_path, first, "x1", 7.0), _file(tmp_path, first, "x2", 7.0)
    x1_6 = _file(tmp_path, first, "x1", 6.0)
    # x1's files copied over x2's (same speed, another drive): a valid file, not x2's
    shutil.copy(x1_7, x2_7)
    shutil.copy(x1_7.with_suffix(".npz"), x2_7.with_suffix(".npz"))
    # a symbolic link to another speed's record
    x1_6.unlink()
    os.symlink(x1_7, x1_6)
    again = _size(tmp_path, LinearBackend())
    by = {(r["candidate"], r["wind_speed_m_s"]): r for r in again.records}
    for (c, w), r in by.items():
        assert r["avg_p_elec_w"] == pytest.approx(_truth(c, w))
    assert "holds the solve of another problem" in by["x2", 7.0]["store_rejected"]
    assert "holds the solve of another problem" in by["x1", 6.0]["store_rejected"]
    assert again.n_solved == 2


def test_the_figures_of_a_record_must_agree(tmp_path):
    # a record written with its hash but contradicting itself (another writer's bug, or
    # a hand-made file that copies the format) is not believed either
    key = "k" * 64
    warm = Solution(np.ones(3), np.zeros(3), np.zeros(1), 1, 1)
    base = {"key": key, "kind": "elec-lim", "wind_speed_m_s": 7.0, "success": True,
            "status": "Solve_Succeeded", "avg_p_elec_w": -500.0, "period_s": 8.0}
    store_solve(tmp_path, key, base, warm)
    stored = read_solve(tmp_path, key, Scenario.of_kind("elec-lim", 7.0))
    assert stored.rejected is None and stored.record["avg_p_elec_w"] == -500.0
    np.testing.assert_array_equal(stored.warm.w, np.ones(3))
    cases = {
        "a converged solve without a finite avg_p_elec_w": {"avg_p_elec_w": float("nan")},
        "a failed solve with avg_p_elec_w": {"success": False},
        "a converged solve with period_s": {"period_s": -1.0},
        "its success or status is missing": {"success": "yes"},
    }
    for why, change in cases.items():
        store_solve(tmp_path, key, {**base, **change}, warm)
        assert why in read_solve(tmp_path, key, Scenario.of_kind("elec-lim", 7.0)).rejected
    store_solve(tmp_path, key, base, warm)
    at_8 = Scenario.of_kind("elec-lim", 8.0)
    assert "holds wind speed 7.0, not 8 m/s" in read_solve(tmp_path, key, at_8).rejected
    mech = Scenario.of_kind("mech-lim", 7.0)
    assert "holds kind 'elec-lim', not 'mech-lim'" in read_solve(tmp_path, key, mech).rejected
    # a .npz of non-finite numbers with its right hash: not a warm start
    store_solve(tmp_path, key, base, replace(warm, w=np.array([1.0, np.inf, 0.0])))
    assert "not finite vectors" in read_solve(tmp_path, key).rejected
    # no record, or a .npz alone (a run stopped between its two writes): nothing stored
    (tmp_path / f"{key}.json").unlink()
    assert read_solve(tmp_path, key) is None


def _sizing_doc(folder, aeps):
    folder.mkdir(parents=True, exist_ok=True)
    doc = {"schema": "drivebench.sizing", "schema_version": 1,
           "candidates": [{"candidate": c, "aep_elec_mwh": a} for c, a in aeps.items()]}
    (folder / "sizing.json").write_text(json.dumps(doc))


def test_a_sizing_whose_solves_crashed_does_not_replace_a_better_one(tmp_path):
    from energy.size_command import earlier_is_better

    crash = {"candidate": "x2", "kind": "elec-lim", "wind_speed_m_s": 8.0, "success": False,
             "status": "worker error: BadZipFile: File is not a zip file"}
    table = pd.DataFrame({"candidate": ["x1", "x2"], "aep_elec_mwh": [0.56, None]})
    now = SimpleNamespace(records=[crash], table=table)
    _sizing_doc(tmp_path / "good", {"x1": 0.56, "x2": 0.51})
    why = earlier_is_better(tmp_path / "good", now)
    assert why is not None and "it has an AEP for x2" in why and "BadZipFile" in why
    # the earlier sizing had no AEP for x2 either: nothing better is lost
    _sizing_doc(tmp_path / "same", {"x1": 0.56, "x2": None})
    assert earlier_is_better(tmp_path / "same", now) is None
    # a solver's own verdict (stored, not transient) is an answer: it is written
    verdict = SimpleNamespace(records=[{**crash, "status": "Infeasible_Problem_Detected"}],
                              table=table)
    assert earlier_is_better(tmp_path / "good", verdict) is None
    # no earlier sizing, or an unreadable one: this run's is written
    assert earlier_is_better(tmp_path / "none", now) is None
    (tmp_path / "bad").mkdir()
    (tmp_path / "bad" / "sizing.json").write_text("{")
    assert earlier_is_better(tmp_path / "bad", now) is None


def test_bench_aep_refine_names_a_stored_solve_it_did_not_believe():
    from energy.refine import refine_notes

    solve = {"wind_speed_m_s": 6.25, "role": "added", "success": True, "status": "ok",
             "store_rejected": "aep_out/solves/abc.json: its content differs from the SHA-256 "
                               "it records (edited or damaged)"}
    doc = {"tol": 0.002, "kinds": {"elec-lim": {
        "solves": [solve, {**solve, "wind_speed_m_s": 7.0, "store_rejected": None}],
        "coarse_aep_elec_mwh": 1.0, "aep_elec_mwh": 1.0, "coarse_aep_mech_mwh": 1.2,
        "aep_mech_mwh": 1.2, "note": None}}}
    lines = [line for line in refine_notes(doc) if line.startswith("stored solve not used")]
    assert lines == ["stored solve not used: aep_out/solves/abc.json: its content differs from "
                     "the SHA-256 it records (edited or damaged); elec-lim 6.25 m/s solved again"]
