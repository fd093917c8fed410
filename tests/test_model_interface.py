"""The OCP's model interface is real: a second model, a point mass on a tether
(tests/point_mass_model.py), runs through the same transcriptions and solver path
as the kite, with no edit to optimize/problem/.

Truth: the period of a free pendulum released at 60 degrees,
``T = 4 sqrt(L/g) K(sin^2(30 deg))`` (complete elliptic integral of the first kind),
7.3 % longer than the small-angle period the guess starts from.
"""

from __future__ import annotations

import numpy as np
import pytest
from point_mass_model import Pendulum, pendulum_formulation, small_angle_guess

from optimize.problem.ocp import assemble, grid_times
from optimize.problem.options import Discretization, OcpOptions, SolverOptions
from optimize.solve.nlp_solver import run
from optimize.solve.result import trajectory_frame

N, DEGREE = 20, 3


@pytest.mark.parametrize("solver", ["ipopt", "fatrop"])
def test_pendulum_cycle_has_the_exact_period(solver):
    pendulum = Pendulum()
    form = pendulum_formulation(pendulum)
    ocp = assemble(form, OcpOptions(Discretization(N, DEGREE), solver=SolverOptions(solver=solver)))
    assert ocp.layout.name == ("stagewise" if solver == "fatrop" else "general")
    assert ocp.layout.i_x.shape[0] == 4 and ocp.layout.i_z.shape[0] == 3
    assert form.dae.states.units == ("m", "m", "m/s", "m/s")  # read from the names
    guess_period = form.scales.period_s
    x, z = small_angle_guess(pendulum, grid_times(ocp, guess_period), guess_period)
    w0 = ocp.pack(x, z[:, 1:], np.zeros((1, N)), np.zeros((2, N * DEGREE)), guess_period)
    p = ocp.params(None, {"p_ctrl_w": 0.0})
    raw = run(ocp, w0, p, ocp.bounds(drive_limits=False, fix_fictitious=True, period_s=None),
              warm=False)
    assert raw.success, raw.status
    sol = ocp.unpack(raw.w)
    # Radau collocation of degree 3 on 20 intervals: the period to 1e-5 relative
    assert sol["period_s"] == pytest.approx(pendulum.period_s(), rel=1e-5)
    # the free swing needs no force: what is left (5e-5 m g here) costs (5e-5)^2 in the
    # regularization, below the solver's tolerance
    assert np.max(np.abs(sol["u"])) < 1e-3 * pendulum.mass_kg * pendulum.g_m_s2
    # the tether keeps its length: the index-reduced constraint (d2c/dt2 = 0 at the Radau
    # points, c and dc/dt zero at the start) drifts by the collocation error only (7e-5 L)
    r = np.hypot(sol["x"][0], sol["x"][1])
    assert np.max(np.abs(r - pendulum.length_m)) < 2e-4 * pendulum.length_m
    traj = trajectory_frame(ocp, raw.w, None)
    assert {"r_x_m", "v_z_m_s", "f_x_n", "nu_n_per_m", "tension_n"} <= set(traj.columns)
    # tension at the lowest point of the swing: m g (3 - 2 cos(theta0)) = 2 m g at 60 deg
    assert traj["tension_n"].max() == pytest.approx(2.0 * pendulum.mass_kg * pendulum.g_m_s2,
                                                    rel=1e-3)


def test_the_objective_weights_are_named_by_the_model():
    form = pendulum_formulation(Pendulum())
    ocp = assemble(form, OcpOptions(Discretization(4, 2)))
    assert set(ocp.layout.params) == {"w_p_ctrl_w", "w_reg", "w_track", "w_fict"}
    with pytest.raises(ValueError, match="p_elec_w"):
        ocp.params(None, {"p_elec_w": 1.0})
