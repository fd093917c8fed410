"""An optimum on the angle-of-attack or sideslip bound of ``[aero]`` is listed in the
summary's ``active_bounds`` (``alpha_min``, ``alpha_max``, ``beta_min``, ``beta_max``), and
each name is explained in the report's legend.

The truth is the trajectory itself: a bound is listed exactly when the solved angle comes
within 1e-3 deg of it (solver tolerance: IPOPT's 1e-8 on the scaled rows of 10 deg), and not
when the angle stays degrees away."""

from __future__ import annotations

from pathlib import Path

import pytest

from optimize.model.kite_model import kite_dae
from optimize.paper_model import paper_model
from optimize.problem.ocp import build_ocp
from optimize.problem.options import OcpOptions
from optimize.problem.scenario import Scenario
from optimize.solve.solve import solve
from optimize.sweep.outputs import KITE_BOUNDS, MEANT_BOUNDS
from optimize.system.drive_in_force import drive_in_force
from optimize.system.system import shipped_system_path
from optimize.system.system_file import load_system
from reports.optimization_section import BOUND_MEANINGS

ANGLES = ("alpha_min", "alpha_max", "beta_min", "beta_max")


def _solve_with(tmp_path: Path, coarse, line: str, tightened: str):
    """The electrical optimum at 7 m/s of highwind.toml with its ``[aero]`` line ``line``
    replaced by ``tightened``, on the grid of the OCP and warm-started from the solve of
    ``coarse`` (an OCP and its solve)."""
    coarse_ocp, coarse_res = coarse
    text = shipped_system_path().read_text()
    assert line in text
    path = tmp_path / "tight.toml"
    path.write_text(text.replace(line, tightened))
    system = load_system(path)
    drive, _ = drive_in_force(system, drive_model=paper_model())
    options = OcpOptions(coarse_ocp.options.discretization)
    ocp = build_ocp(kite_dae(*system.model_params()), paper_model(), options,
                    system=system.in_force(drive))
    res = solve(ocp, Scenario(7.0, "electrical", True), coarse_res.warm)
    assert res.success, res.status
    return res


def test_the_paper_optimum_lists_the_angle_bounds_it_sits_on(coarse_elec_lim):
    # the paper's optimum flies at its 8.5 deg angle of attack and -9 deg sideslip, and
    # stays degrees inside the other two ends of [-4.5, 8.5] and [-9, 9] deg
    traj, active = coarse_elec_lim.trajectory, coarse_elec_lim.active_bounds
    assert traj["alpha_deg"].max() == pytest.approx(8.5, abs=1e-3)
    assert traj["beta_deg"].min() == pytest.approx(-9.0, abs=1e-3)
    assert traj["alpha_deg"].min() > -4.5 + 1.0
    assert traj["beta_deg"].max() < 9.0 - 1.0
    assert {"alpha_max", "beta_min"} <= set(active), active
    assert not {"alpha_min", "beta_max"} & set(active), active


def test_a_tightened_alpha_bound_in_the_system_file_is_listed(tmp_path, coarse_ocp,
                                                             coarse_elec_lim):
    coarse = (coarse_ocp, coarse_elec_lim)
    low = _solve_with(tmp_path, coarse, "alpha_min_deg = -4.5", "alpha_min_deg = 2.0")
    assert low.trajectory["alpha_deg"].min() == pytest.approx(2.0, abs=1e-3)
    assert "alpha_min" in low.active_bounds, low.active_bounds
    high = _solve_with(tmp_path, coarse, "alpha_max_deg = 8.5", "alpha_max_deg = 6.0")
    assert high.trajectory["alpha_deg"].max() == pytest.approx(6.0, abs=1e-3)
    assert high.trajectory["alpha_deg"].min() > -4.5 + 1.0
    assert "alpha_max" in high.active_bounds, high.active_bounds
    assert "alpha_min" not in high.active_bounds, high.active_bounds


def test_the_angle_bounds_are_the_kites_and_every_name_is_explained():
    # the angle ranges are where the aero coefficients hold: the kite's limit, not a
    # search range, so an optimum on one is not flagged bound_limited
    assert set(ANGLES) <= set(KITE_BOUNDS)
    names = {*MEANT_BOUNDS, "period_min", "period_max", "tether_length_min",
             "tether_length_max"}
    assert not names - set(BOUND_MEANINGS), names - set(BOUND_MEANINGS)
