"""The OCP's option groups and the transcription's named rows."""

from __future__ import annotations

import json

import numpy as np
import pytest
from system_fixtures import system_for

from optimize.model import kite_model as km
from optimize.model.kite_model import kite_dae
from optimize.paper_model import paper_model
from optimize.problem.ocp import build_ocp
from optimize.problem.options import Discretization, OcpOptions, SolverOptions


def test_options_round_trip_through_json():
    opts = OcpOptions(Discretization(n_intervals=12, degree=3, control_sigma=(5, 1, 1, 1)),
                      SolverOptions(tol=1e-8, stored_guess=False))
    back = OcpOptions.from_dict(json.loads(json.dumps(opts.as_dict())))
    assert back == opts and back.discretization.control_sigma == (5, 1, 1, 1)
    # the bounds are the system's, not options (an older manifest's group is refused)
    with pytest.raises(TypeError, match="unknown option groups: limits"):
        OcpOptions.from_dict({**opts.as_dict(), "limits": {"max_torque_nm": 60.0}})


def test_replace_changes_one_group_field_and_rejects_unknown_groups():
    opts = OcpOptions().replace(solver={"tol": 1e-8})
    assert opts.solver.tol == 1e-8 and opts.discretization == Discretization()
    with pytest.raises(TypeError, match="unknown option groups"):
        OcpOptions().replace(mesh={"n_intervals": 3})
    with pytest.raises(TypeError):
        OcpOptions.from_dict({"discretization": {"n_intervals": 10, "nodes": 3}})


@pytest.mark.parametrize("bad", [dict(n_intervals=1), dict(degree=0),
                                 dict(control_sigma=(1.0, 1.0, 1.0))])
def test_discretization_rejects_out_of_range(bad):
    with pytest.raises(ValueError):
        Discretization(**bad)


def test_rows_are_found_by_name_and_the_drive_limits_bound_only_their_rows():
    n, d = 4, 3
    drive = {"max_torque_nm": 78.0, "max_p_elec_w": 5000.0, "continuous_torque_nm": 50.0}
    ocp = build_ocp(kite_dae(), paper_model(), OcpOptions(Discretization(n, d)),
                    system=system_for(drive=drive))
    lay = ocp.layout
    per_point = {"dynamics": km.STATES.size, "algebraic": km.ALGEBRAIC.size, "airspeed": 1,
                 "alpha": 1, "beta": 1, "line_angle": 1, "torque": 1, "p_elec": 1}
    for name, size in per_point.items():
        assert lay.rows_of(name).size == n * d * size, name
    assert lay.rows_of("periodic").size == 13 + 3 and lay.rows_of("rms_torque").size == 1
    every = np.concatenate(list(lay.rows.values()))
    assert np.array_equal(np.sort(every), np.arange(lay.n_g))  # each row named exactly once
    free, limited = ocp.bounds(False, True, None), ocp.bounds(True, True, None)
    changed = np.flatnonzero((free[2] != limited[2]) | (free[3] != limited[3]))
    want = np.concatenate([lay.rows_of(k) for k in ("torque", "p_elec", "rms_torque")])
    assert np.array_equal(changed, np.sort(want))
    sc = ocp.scales
    assert limited[3][lay.rows_of("torque")] == pytest.approx(78.0 / sc.torque_nm)
    changed_w = np.flatnonzero((free[0] != limited[0]) | (free[1] != limited[1]))
    assert np.array_equal(changed_w, np.sort(lay.i_x[km.STATES.index("dl_m_s")]))
