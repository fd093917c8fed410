"""A model part added in one file: a first-order filter of the reel speed.

The part (:class:`ReelFilter`, below) brings its own state, bound, scale, start guess
and output column (declared with its unit suffix); one line registers it
(``build_ocp(..., parts=...)``), or, with its section of the system file
(:class:`ReelFilterInputs`, one key), one line in ``PART_SECTIONS``: then a system file
with ``[reel_filter]`` flies it through ``bench optimize --system`` and
docs/system_file.md shows its key. Truths:

* the filter's output is a weighted average of its input (``f' = (dl - f) / tau``), so
  ``|f| <= max |dl|``: its bound at the drive's reel-speed limit holds and never binds,
  and the kite's optimum is the one without the part (same mesh, same start);
* an independent integration (scipy's RK45) of the filter over repeated cycles of the
  optimal reel speed ends on the OCP's periodic filter state.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from system_fixtures import system_for

from drivebench.cli import main
from kernel.files import write_parquet
from kernel.sections import number
from optimize.model.kite_model import kite_dae
from optimize.model.variables import Variables
from optimize.paper_model import paper_model
from optimize.problem.ocp import build_ocp
from optimize.problem.options import SOLVER_REEL_SPEED_M_S, Discretization, OcpOptions
from optimize.problem.part import Part, StartPoint, trajectory_columns
from optimize.problem.part_sections import PART_SECTIONS
from optimize.service.outcome import Attempt, ScenarioOutcome
from optimize.solve.starts import stored_guess
from optimize.solve.starts.cold import start
from optimize.sweep.outputs import trajectories_frame
from optimize.sweep_folder import field_units, read_summary, read_trajectories
from optimize.system import system_doc
from optimize.system.system import shipped_system_path

TAU_S = 0.5
DOC = Path(__file__).resolve().parent.parent / "docs" / "system_file.md"


@dataclass(frozen=True)
class ReelFilter(Part):
    """``tau df/dt = dl - f``: the reel speed [m/s] through a first-order lag."""

    tau_s: float
    bound_m_s: float
    name: str = "reel_filter"
    states: Variables = Variables(("dl_filtered_m_s",))
    periodic: tuple[str, ...] = ("dl_filtered_m_s",)
    output_columns: tuple[str, ...] = ("filter_lag_m_s",)

    def rates(self, q: Mapping[str, Any]) -> list[Any]:
        return [(q["dl_m_s"] - q["dl_filtered_m_s"]) / self.tau_s]

    def bounds(self) -> dict[str, tuple[float, float]]:
        return {"dl_filtered_m_s": (-self.bound_m_s, self.bound_m_s)}

    def scales(self) -> dict[str, float]:
        return {"dl_filtered_m_s": 5.0}

    def outputs(self, q: Mapping[str, Any]) -> dict[str, Any]:
        return {"filter_lag_m_s": q["dl_m_s"] - q["dl_filtered_m_s"]}

    def guess(self, start: StartPoint) -> dict[str, np.ndarray]:
        return {"dl_filtered_m_s": start.on_grid(start.quantities["dl_m_s"])}


@dataclass(frozen=True, kw_only=True)
class ReelFilterInputs:
    """The reel speed through a first-order lag: ``tau df/dt = dl - f`` (a test part)."""

    time_constant_s: float = number("the filter's time constant tau", lo=0)

    def part(self, dae: Any, scales: Any) -> ReelFilter:
        """The filter, bounded by the solver's reel-speed range (it never binds)."""
        return ReelFilter(self.time_constant_s, SOLVER_REEL_SPEED_M_S)


@pytest.fixture(scope="module")
def flown(tmp_path_factory):
    """``bench optimize --system`` of the paper's kite with ``[reel_filter]``, the part
    registered by one line (one worker process: the system carries the part's inputs)."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setitem(PART_SECTIONS, "reel_filter", ReelFilterInputs)  # the registration
        work = tmp_path_factory.mktemp("flown")
        mp.chdir(work)  # no fit_out/ here: the paper's drive model
        system = work / "filtered.toml"
        system.write_text(shipped_system_path().read_text(encoding="utf-8")
                          + f"\n[reel_filter]\ntime_constant_s = {TAU_S}\n", encoding="utf-8")
        code = main(["optimize", "--system", str(system), "--wind-grid", "7", "--scenarios",
                     "elec-lim", "--no-claims", "--no-progress", "--workers", "1",
                     "--out", str(work / "out")])
        page = system_doc.render(DOC.read_text(encoding="utf-8"))
    return code, work / "out", page


def test_a_part_registered_by_one_line_flies_from_the_command_line(flown, stored_guess_solve):
    code, out, page = flown
    assert code == 0
    summary = read_summary(out / "summary.parquet").iloc[0]
    assert summary["success"] and summary["scenario"] == "elec-lim-7.0"
    # the kite's optimum is the one without the part (started by the homotopy here: a
    # system with another section is another system for the stored guess)
    assert summary["avg_p_elec_w"] == pytest.approx(stored_guess_solve.avg_p_elec_w, rel=1e-4)
    traj = read_trajectories(out)
    units = field_units(out / "trajectories.parquet")
    assert units["dl_filtered_m_s"] == "m/s" and units["filter_lag_m_s"] == "m/s"
    assert np.allclose(traj["filter_lag_m_s"], traj["dl_m_s"] - traj["dl_filtered_m_s"])
    # its key in the generated docs/system_file.md, and in no other section
    assert "### `[reel_filter]` (optional)" in page
    assert "| `time_constant_s` | s | > 0 | required | the filter's time constant tau |" in page
    assert "time_constant_s" not in DOC.read_text(encoding="utf-8")


@pytest.fixture(scope="module")
def filtered(paper_ocp):
    """The paper's OCP with the filter, started as any scenario is (the stored guess, the
    filter filling its own state), at the guess's scenario elec-lim 7 m/s."""
    bound = paper_ocp.formulation.limited_state_bounds()[
        paper_ocp.dae.states.index("dl_m_s")][1]
    ocp = build_ocp(kite_dae(), paper_model(), OcpOptions(),
                    parts=(ReelFilter(TAU_S, bound),), system=system_for())
    return ocp, start(ocp, stored_guess.GUESS_SCENARIO), bound


def test_the_part_changes_nothing_of_the_kites_optimum(filtered, stored_guess_solve):
    ocp, res, _ = filtered
    assert res.success and stored_guess_solve.success, (res.status, stored_guess_solve.status)
    assert res.start == "stored guess"  # the stored guess still fits, the part filled in
    assert ocp.dae.states.names[-1] == "dl_filtered_m_s"
    assert res.avg_p_elec_w == pytest.approx(stored_guess_solve.avg_p_elec_w, abs=1e-3)
    assert res.avg_p_mech_w == pytest.approx(stored_guess_solve.avg_p_mech_w, abs=1e-3)
    assert res.period_s == pytest.approx(stored_guess_solve.period_s, rel=1e-6)


def test_the_filter_state_is_in_the_trajectories_with_its_unit(filtered, tmp_path):
    _, res, bound = filtered
    outcome = ScenarioOutcome(res.scenario, 0,
                              (Attempt(None, res.status, True, res.iterations, 1.0),), res)
    columns = trajectory_columns(filtered[0].formulation.parts)
    assert list(res.trajectory.columns) == list(columns)  # the parts' columns, in order
    for name, outcomes in (("trajectories", [outcome]), ("empty", [])):  # nothing converged
        path = write_parquet(tmp_path / f"{name}.parquet", trajectories_frame(outcomes, columns))
        units = field_units(path)
        assert units["dl_filtered_m_s"] == "m/s" and units["filter_lag_m_s"] == "m/s"
        assert list(units) == ["scenario", "kind", "wind_speed_m_s", *columns]
    traj = res.trajectory
    f, dl = traj["dl_filtered_m_s"].to_numpy(), traj["dl_m_s"].to_numpy()
    # a weighted average of the reel speed: inside its range, so inside the bound
    assert np.abs(f).max() <= np.abs(dl).max() + 1e-6 and np.abs(f).max() <= bound
    assert np.allclose(traj["filter_lag_m_s"], dl - f)


def test_the_filter_state_is_the_periodic_solution_of_its_ode(filtered):
    """RK45 over 10 cycles of the optimal reel speed (linear between the Radau points)
    from the OCP's end value ends within 1 % of the peak reel speed of it."""
    _, res, _ = filtered
    traj, period = res.trajectory, float(res.period_s)
    t, dl = traj["time_s"].to_numpy(), traj["dl_m_s"].to_numpy()
    f_end = traj["dl_filtered_m_s"].to_numpy()[-1]  # the last Radau point is the period's end

    def rhs(time, y):
        return [(np.interp(np.mod(time, period), t, dl, period=period) - y[0]) / TAU_S]

    sim = solve_ivp(rhs, (0.0, 10 * period), [f_end], rtol=1e-9, atol=1e-9,
                    max_step=period / 200)
    assert abs(sim.y[0, -1] - f_end) < 0.01 * np.abs(dl).max()


@dataclass(frozen=True)
class Push(Part):
    """A constant force [N] (world NED) and moment [N m] (body) on the kite."""

    force_n: tuple[float, float, float]
    moment_nm: tuple[float, float, float]
    name: str = "push"

    def quantities(self, q: Mapping[str, Any]) -> dict[str, Any]:
        axes = zip("xyz", self.force_n, self.moment_nm, strict=True)
        return {k: q.get(k, 0) + v for a, f, m in axes
                for k, v in ((f"f_ext_{a}_n", f), (f"m_ext_{a}_nm", m))}


def test_a_force_from_another_part_enters_the_kites_newton_euler_rows():
    """Newton's and Euler's residuals drop by the force and moment over their scales
    (``m a + ... - F_aero - m g - F_ext``), the tether row not at all; at a random point."""
    opts = OcpOptions(Discretization(n_intervals=2, degree=1))
    force, moment = (3.0, -2.0, 40.0), (0.5, 0.0, -1.5)
    plain = build_ocp(kite_dae(), paper_model(), opts, system=system_for())
    pushed = build_ocp(kite_dae(), paper_model(), opts, parts=(Push(force, moment),),
        system=system_for())
    dae, rng = plain.dae, np.random.default_rng(3)
    x, u = rng.normal(size=dae.states.size), rng.normal(size=dae.controls.size)
    z, fict = rng.normal(size=dae.algebraic.size), rng.normal(size=dae.fictitious.size)

    def algebraic(ocp):
        rows = ocp.formulation.point(x, u, z, fict, [7.0]).rows
        return np.asarray(next(r.expr for r in rows if r.name == "algebraic")).ravel()

    want = -np.array([*force, *moment, 0.0]) / plain.scales.residual
    assert np.allclose(algebraic(pushed) - algebraic(plain), want, rtol=1e-9, atol=1e-12)


@dataclass(frozen=True)
class Undeclared(ReelFilter):
    """The filter with an output its ``output_columns`` do not declare, and one without
    a unit suffix."""

    output_columns: tuple[str, ...] = ("filter_lag_m_s", "filter_gain")

    def outputs(self, q: Mapping[str, Any]) -> dict[str, Any]:
        return {**super().outputs(q), "filter_input_m_s": q["dl_m_s"]}


def test_a_part_s_columns_are_its_declared_ones_each_with_a_unit():
    opts = OcpOptions(Discretization(n_intervals=2, degree=1))
    part = Undeclared(TAU_S, 10.0)
    ocp = build_ocp(kite_dae(), paper_model(), opts, parts=(part,), system=system_for())
    with pytest.raises(ValueError, match="part 'reel_filter': outputs.. gives"):
        dae = ocp.dae
        ocp.formulation.trajectory_outputs(
            *(np.zeros((v.size, 1)) for v in (dae.states, dae.controls, dae.algebraic)), [7.0])
    with pytest.raises(ValueError, match="'filter_gain' has no unit suffix"):
        trajectory_columns(ocp.formulation.parts)
    with pytest.raises(ValueError, match="'dl_filtered_m_s' is given twice"):
        trajectory_columns((*ocp.formulation.parts, ReelFilter(TAU_S, 10.0)))
