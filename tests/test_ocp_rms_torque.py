"""The continuous-rating option of the OCP: RMS drum torque over the cycle <= rated torque."""

from __future__ import annotations

import numpy as np
import pytest
from system_fixtures import system_for

from optimize.model.kite_model import kite_dae
from optimize.paper_model import paper_model
from optimize.problem.ocp import build_ocp
from optimize.problem.options import Discretization, OcpOptions
from optimize.problem.scenario import Scenario
from optimize.solve.solve import solve
from optimize.solve.starts import stored_guess

N_COARSE = 10


def _rms(traj) -> float:
    return float(np.sqrt(np.sum(traj["weight"] * traj["torque_nm"] ** 2)))


def test_rms_torque_bound_binds_and_costs_power(coarse_ocp, coarse_elec_lim):
    # the coarse OCP's elec-lim optimum (warm from its cold start) is shared (conftest.py)
    dae, ref = coarse_ocp.dae, coarse_elec_lim
    assert coarse_ocp.n_intervals == N_COARSE and not coarse_ocp.system.drive.rms_torque_limit_nm
    scenario = Scenario(7.0, "electrical", True)
    assert ref.success, ref.status
    rms_free = _rms(ref.trajectory)
    # a rating 15 % below the unconstrained cycle's RMS torque, peak limit unchanged
    rated = 0.85 * rms_free
    ocp = build_ocp(dae, paper_model(), OcpOptions(Discretization(n_intervals=N_COARSE)),
                    system=system_for(drive={"continuous_torque_nm": rated}))
    assert ocp.layout.rows_of("rms_torque").size == 1
    warm = ref.warm.__class__(ref.warm.w, ref.warm.lam_x, np.append(ref.warm.lam_g, 0.0),
                              ref.warm.n_intervals, ref.warm.degree)
    res = solve(ocp, scenario, warm)
    assert res.success, res.status
    # the row is the quadrature mean of T^2 (scaled 1e-4), solved to 1e-6: 0.1 % in RMS
    assert _rms(res.trajectory) == pytest.approx(rated, rel=1e-3)
    assert res.avg_p_elec_w > ref.avg_p_elec_w  # less generated (negative = generated)
    # without drive limits the row is free
    lo, hi = ocp.bounds(drive_limits=False, fix_fictitious=True, period_s=None)[2:]
    assert np.isinf(hi[ocp.layout.rows_of("rms_torque")]).all()


def test_stored_guess_fits_an_ocp_with_the_rms_row():
    ocp = build_ocp(kite_dae(), paper_model(), OcpOptions(),
                    system=system_for(drive={"continuous_torque_nm": 70.0}))
    guess, why = stored_guess.load(ocp)
    assert guess is not None, why
    assert guess.lam_g.size == ocp.layout.n_g
