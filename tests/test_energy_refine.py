"""``bench aep --refine`` (energy.refine) on a synthetic solver with kinks of known AEP."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from scipy import integrate, stats

from energy.aep import aep_mwh
from energy.curve import PowerCurve
from energy.refine import KindTask, merged_curve, refine_kind
from energy.site import Weibull
from optimize.paper_model import paper_model
from optimize.problem.options import OcpOptions
from optimize.problem.scenario import Scenario
from optimize.solve.result import Solution

V_IN, CAP_W = 4.3, 2000.0  # cut-in [m/s]; a drive limit caps the delivered power [W]
KINKS = (V_IN, (CAP_W * V_IN / 35.0 + V_IN**3) ** (1 / 3), (2.5 * CAP_W / 9.0) ** (1 / 3))  # [m/s]
COARSE = (4.0, 5.5, 7.0, 8.5, 10.0)
SITE = Weibull.from_mean(2.0, 5.5)


def p_elec(v: float) -> float:
    """Consumes below V_IN, grows with the cube, capped at CAP_W (at 6.88 m/s)."""
    return 60.0 * (V_IN - v) if v < V_IN else -min(CAP_W, 35.0 * (v**3 - V_IN**3) / V_IN)


def p_mech(v: float) -> float:
    return -min(2.5 * CAP_W, 9.0 * v**3)


def exact_aep(p) -> float:
    """8760 h x integral over the grid's range of max(-P, 0) f_Weibull (adaptive quadrature
    split at the kinks): the truth, independent of energy.aep's piecewise-linear formula."""
    pdf = stats.weibull_min(SITE.k, scale=SITE.scale_m_s).pdf
    val, _ = integrate.quad(lambda v: max(-p(v), 0.0) * pdf(v), 4.0, 10.0,
                            points=KINKS, limit=200, epsabs=1e-9)
    return val * 8760 / 1e6


class KinkBackend:
    """The chain backend protocol with the closed-form curves above; counts its solves."""

    def __init__(self, fail_at=(), crash_at=()):
        self.fail_at, self.crash_at, self.calls = set(fail_at), set(crash_at), []

    def build(self, problem):
        return "ocp"

    def _result(self, wind, start):
        self.calls.append(wind)
        ok = wind not in self.fail_at
        traj = pd.DataFrame({"weight": [0.5, 0.5], "speed_rpm": [-100 * wind, 50 * wind],
                             "torque_nm": [5 * wind, 2.0]})
        return SimpleNamespace(success=ok, status="Solve_Succeeded" if ok else "Infeasible",
                               iterations=5, wall_time_s=1e-3,
                               start=start, avg_p_elec_w=p_elec(wind), avg_p_mech_w=p_mech(wind),
                               period_s=10.0, trajectory=traj,
                               warm=Solution(np.array([wind]), np.zeros(1), np.zeros(1), 1, 1))

    def solve(self, ocp, scenario, warm):
        wind = scenario.wind_speed_m_s
        assert isinstance(warm, Solution)  # from memory or from the store's npz
        return self._result(wind, "warm start")

    def cold_start(self, ocp, scenario):
        wind = scenario.wind_speed_m_s
        if wind in self.crash_at:
            raise RuntimeError("solver crashed")
        return self._result(wind, "stored guess")

    def check(self, ocp, result, name):
        return None  # an exact stand-in solver: nothing to check


def _task(tmp_path, backend, kind="elec-lim"):
    known = tuple((v, p_elec(v), p_mech(v)) for v in COARSE)
    return KindTask(kind, paper_model(), OcpOptions(), known, SITE, tmp_path / "solves",
                    backend=backend)


def _coarse_curve() -> PowerCurve:
    w = np.array(COARSE)
    return PowerCurve("elec-lim", "electrical", True, w, np.array([p_elec(v) for v in w]),
                      np.array([p_mech(v) for v in w]), np.full(5, 10.0), np.ones(5),
                      np.ones(5), tuple(f"elec-lim-{v:.1f}" for v in w))


def test_refined_aep_is_within_1_percent_of_the_exact_one_where_the_sweep_grid_is_not(tmp_path):
    backend = KinkBackend()
    records = refine_kind(_task(tmp_path, backend))
    curve = merged_curve(_coarse_curve(), tuple(records))
    truth_e, truth_m = exact_aep(p_elec), exact_aep(p_mech)
    coarse_e = aep_mwh(np.array(COARSE), np.array([p_elec(v) for v in COARSE]), SITE)
    # the bar: 1 % (of the AEP against a dense grid; here against the exact integral)
    assert abs(coarse_e / truth_e - 1) > 0.01
    assert aep_mwh(curve.wind_speed_m_s, curve.p_elec_w, SITE) == pytest.approx(truth_e, rel=0.01)
    assert aep_mwh(curve.wind_speed_m_s, curve.p_mech_w, SITE) == pytest.approx(truth_m, rel=0.01)
    added = [r for r in records if r["role"] == "added"]
    assert added and all(r["success"] for r in added)
    # fewer solves than a 0.25 m/s grid (25 points), each speed once, one check re-solve
    assert len(backend.calls) < 25 and len(set(backend.calls)) == len(backend.calls)
    assert [r["role"] for r in records].count("check") == 1
    assert sum(curve.added) == len(added)
    assert all(r["warm_from"].endswith("m/s") for r in added)  # warm-started from a neighbour
    # the basis averages of an added point are those of its trajectory (for the bands)
    r = added[0]
    v = r["wind_speed_m_s"]
    n, t = np.array([-100 * v, 50 * v]), np.array([5 * v, 2.0])
    expected = [np.mean(n**i * t**j) for i, j in paper_model().terms]
    assert r["basis_averages"] == pytest.approx(expected, rel=1e-12)


class CycleBackend(KinkBackend):
    """:class:`KinkBackend` that also takes a stored cycle as a start (its trajectory's one
    ``wind`` value is the start's wind speed) and records where each solve started."""

    def __init__(self):
        super().__init__()
        self.cold = []

    def from_trajectory(self, ocp, trajectory):
        return Solution(trajectory["wind"].to_numpy(), np.zeros(1), np.zeros(1), 1, 1)

    def cold_start(self, ocp, scenario):
        wind = scenario.wind_speed_m_s
        self.cold.append(wind)
        return super().cold_start(ocp, scenario)


def test_each_added_speed_starts_from_the_nearest_solved_speed_the_sweeps_included(tmp_path):
    # issue 40 item 3: the sweep's stored cycles are solved neighbours too: the check
    # re-solve starts from its own cycle, every added speed from the nearest speed solved
    # before it (sweep or added), and nothing starts cold
    from energy.refine import sweep_starts
    from optimize.service.foreign import CycleStart

    starts = tuple(CycleStart(Scenario.of_kind("elec-lim", v), "sweep",
                              trajectory=pd.DataFrame({"wind": [v]})) for v in COARSE)
    backend = CycleBackend()
    task = _task(tmp_path, backend)
    records = refine_kind(KindTask(**{**task.__dict__, "starts": starts}))
    assert backend.cold == []
    check = next(r for r in records if r["role"] == "check")
    assert check["warm_from"] == f"sweep {check['wind_speed_m_s']:g} m/s"
    solved = set(COARSE)
    by_wind = {r["wind_speed_m_s"]: r for r in records}
    for wind in backend.calls[1:]:  # in solve order, after the check
        source = float(by_wind[wind]["warm_from"].split()[-2])
        assert abs(source - wind) == pytest.approx(min(abs(s - wind) for s in solved)), wind
        solved.add(wind)
    assert len(backend.calls) > 3
    # a sweep folder without trajectories offers no cycle (the check then starts cold)
    assert sweep_starts(SimpleNamespace(folder=tmp_path, curves={}), 160) == {}
    # a cycle on another mesh than the sweep's (the finer-mesh retry's) is not offered
    columns = ("scenario", "kind", "wind_speed_m_s", "time_s", "weight", "l_m", "speed_rpm",
               "torque_nm", "p_elec_w", "p_mech_w")
    rows = [dict.fromkeys(columns, 0.0) | {"scenario": f"elec-lim-{w:g}", "kind": "elec-lim",
                                            "wind_speed_m_s": w}
            for w, n in ((7.0, 3), (8.5, 6)) for _ in range(n)]
    pd.DataFrame(rows).to_parquet(tmp_path / "trajectories.parquet")
    curve = SimpleNamespace(wind_speed_m_s=[7.0, 8.5], scenarios=["elec-lim-7", "elec-lim-8.5"])
    offered = sweep_starts(SimpleNamespace(folder=tmp_path, curves={"elec-lim": curve}), 3)
    assert [s.scenario.wind_speed_m_s for s in offered["elec-lim"]] == [7.0]


def test_a_stored_cycle_is_the_optimum_it_was_stored_from():
    # the trajectory of an optimum, packed back, is that optimum's primal point (up to the
    # cycle's start state, which the file keeps as the end state: equal where periodic),
    # and a warm solve from it stays on that optimum
    from energy.sizing import scaled_candidates
    from optimize.service import OcpBackend
    from optimize.solve.result import trajectory_frame
    from optimize.system.drive_in_force import drive_in_force
    from optimize.system.system_file import load_system

    system = load_system()
    rating = drive_in_force(system, drive_model=paper_model())[0].rating_part()
    x1 = scaled_candidates(rating.with_losses(paper_model()), (1.0,))[0]
    backend = OcpBackend()
    ocp = backend.build(x1.problem(10, 4, system))
    scenario = Scenario.of_kind("elec-lim", 7.0)
    first = backend.cold_start(ocp, scenario)
    assert first.success, first.status
    start = backend.from_trajectory(ocp, trajectory_frame(ocp, first.warm.w, 7.0))
    assert np.abs(start.w - first.warm.w).max() < 1e-3  # scaled units: O(1) entries
    again = backend.solve(ocp, scenario, start)
    assert again.success and again.avg_p_elec_w == pytest.approx(first.avg_p_elec_w, abs=0.01)


def test_a_rerun_loads_every_solve_from_the_store(tmp_path):
    first = refine_kind(_task(tmp_path, KinkBackend()))
    backend = KinkBackend()
    second = refine_kind(_task(tmp_path, backend))
    assert backend.calls == []
    assert [r["wind_speed_m_s"] for r in second] == [r["wind_speed_m_s"] for r in first]
    assert all(r["cached"] for r in second)


def test_a_failed_added_solve_is_reported_not_dropped(tmp_path):
    records = refine_kind(_task(tmp_path, KinkBackend(fail_at={4.75})))
    failed = [r for r in records if not r["success"]]
    assert [r["wind_speed_m_s"] for r in failed] == [4.75]
    curve = merged_curve(_coarse_curve(), tuple(records))
    assert 4.75 not in curve.wind_speed_m_s
    assert (4.75, "added by --refine: Infeasible") in curve.failed


def test_a_solver_crash_fails_that_speed_only(tmp_path):
    records = refine_kind(_task(tmp_path, KinkBackend(fail_at={4.75}, crash_at={4.75})))
    bad = [r for r in records if not r["success"]]
    assert [r["wind_speed_m_s"] for r in bad] == [4.75]
    assert bad[0]["status"] == "exception: RuntimeError: solver crashed"
    assert sum(r["success"] for r in records if r["role"] == "added") >= 2  # refinement went on


def test_refine_without_the_sweeps_options_is_a_clear_input_error(tmp_path, capsys):
    # a folder whose manifest has no OCP options cannot be refined consistently: exit 2,
    # naming the manifest and the key, and nothing written
    from energy_fixtures import model_with_covariance, write_optimize_folder

    from drivebench.cli import main

    folder = write_optimize_folder(tmp_path / "opt", model_with_covariance())
    out = tmp_path / "aep"
    code = main(["aep", "--optimize", str(folder), "--out", str(out), "--refine",
                 "--weibull-k", "2", "--mean-speed", "5.5", "--no-progress"])
    err = capsys.readouterr().err
    assert code == 2 and "manifest.json" in err and "options" in err
    assert not (out / "aep.json").exists()
    code = main(["aep", "--optimize", str(folder), "--out", str(out), "--refine",
                 "--refine-tol", "0", "--weibull-k", "2", "--mean-speed", "5.5"])
    assert code == 2 and "--refine-tol" in capsys.readouterr().err


def test_the_sweeps_system_is_rebuilt_from_its_manifest_record(tmp_path):
    from energy.refine import system_from_manifest
    from kernel.errors import InputError
    from optimize.system.system_file import load_system

    system = load_system()
    rebuilt = system_from_manifest({"system": system.record()}, tmp_path / "manifest.json")
    assert rebuilt.sha256 == system.sha256 and rebuilt.model_params() == system.model_params()
    assert system_from_manifest({}, tmp_path / "manifest.json") is None  # pre-system sweeps
    tampered = {**system.record(), "text": system.text.replace("mass_kg", "mass_kg ", 1)
                + "\n# edited\n", "sha256": "0" * 64}
    with pytest.raises(InputError, match="sha256"):
        system_from_manifest({"system": tampered}, tmp_path / "manifest.json")
    # the drive it flew, as the manifest records it (read as a drive: the envelope's table a
    # tuple of floats), a key it does not record the file's; a record not a drive refused
    flown = {"max_torque_nm": 70.0, "envelope_speed_rpm": [0, 1000, 1500],
             "envelope_torque_nm": [70, 70, 50]}
    rebuilt = system_from_manifest({"system": system.record(), "sections": {"drive": flown}},
                                   tmp_path / "manifest.json")
    assert rebuilt.drive.max_torque_nm == 70.0
    assert rebuilt.drive.envelope_torque_nm == (70.0, 70.0, 50.0)
    assert rebuilt.drive.max_speed_rpm == system.drive.max_speed_rpm == 1500.0
    with pytest.raises(InputError, match=r"manifest.json.*sections\.drive: unknown key"):
        system_from_manifest({"system": system.record(), "sections": {"drive": {"torque": 1}}},
                             tmp_path / "manifest.json")


def test_refine_progress_never_sits_at_100_percent_while_solves_run():
    # issue 42: aep --refine's bar grew its total with each finished solve (always 100 %)
    import io

    from energy.refine import solve_counter

    out = io.StringIO()
    bar = solve_counter("refine", True, file=out)
    for _ in range(3):
        bar.update(1)
        assert "%" not in out.getvalue()
    bar.close()
    assert "3solve" in out.getvalue().replace(" ", "") and "%" not in out.getvalue()


def test_a_manifest_of_the_older_layout_is_refused_naming_it_and_the_remedy(tmp_path):
    # schema version 1 carried the bounds as options.limits; --refine must not guess them
    from energy.refine import options_from_manifest
    from kernel.errors import InputError

    path = tmp_path / "manifest.json"
    old = {"schema_version": 1, "options": {"discretization": {}, "solver": {},
                                            "limits": {"max_torque_nm": 78.0}}}
    with pytest.raises(InputError) as err:
        options_from_manifest(old, path)
    text = err.value.describe()
    assert str(path) in text and "schema version 1" in text
    assert "re-run `bench optimize`" in text
