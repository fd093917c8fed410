"""The NLP's derivatives built point by point equal those of the whole NLP."""

import dataclasses

import casadi as ca
import numpy as np
import pytest

from optimize.model.kite_model import kite_dae
from optimize.problem.ocp import build_ocp
from optimize.problem.options import Discretization, OcpOptions
from optimize.solve.derivatives import _block_derivatives, nlp_derivatives, whole_derivatives
from optimize.system.drive import drive_in_force
from optimize.system.system import load_system

N = 6  # intervals: every kind of row and variable, small enough to differentiate whole


@pytest.fixture(scope="module")
def ocp():
    """The shipped system with its drive's limits and an RMS-torque rating (a row on a
    cycle sum)."""
    system = load_system()
    drive = drive_in_force(system)
    options = system.ocp_options(OcpOptions(Discretization(n_intervals=N)), drive.rating)
    options = options.replace(limits={"max_rms_torque_nm": 0.5 * options.limits.max_torque_nm})
    return build_ocp(kite_dae(*system.model_params()), drive.model, options, system=system)


def _dense(value) -> np.ndarray:
    return np.array(ca.densify(ca.DM(value)))


def test_point_by_point_equals_whole_nlp(ocp):
    """Gradient, Jacobian and Hessian agree entry by entry (1e-12 of the largest
    entry) with the same sparsity, at a point with every homotopy weight on."""
    lay = ocp.layout
    assert ocp.transcription.blocks is not None and lay.rows_of("rms_torque").size == 1
    rng = np.random.default_rng(3)
    x = 1.0 + 0.1 * rng.normal(size=lay.n_w)  # scaled variables are of order one
    p = ocp.params(7.0, w_elec=1.0, w_mech=0.4, w_track=0.3, w_fict=0.2)
    lam_g = rng.normal(size=lay.n_g)
    blocks, whole = nlp_derivatives(ocp.transcription), whole_derivatives(ocp.nlp)
    for name, args in (("grad_f", (x, p)), ("jac_g", (x, p)), ("hess_lag", (x, p, 1.3, lam_g))):
        new, ref = blocks[name](*args), whole[name](*args)
        new, ref = (new, ref) if isinstance(ref, (list, tuple)) else ([new], [ref])
        for a, b in zip(new, ref, strict=True):
            assert ca.DM(a).nnz() == ca.DM(b).nnz(), name
            a, b = _dense(a), _dense(b)
            finite = np.isfinite(b)
            assert np.array_equal(finite, np.isfinite(a)), name
            scale = np.abs(b[finite]).max()
            assert np.abs(a[finite] - b[finite]).max() <= 1e-12 * scale, name


def test_sums_not_linear_in_the_integrands_fall_back_to_the_whole_nlp(ocp):
    """A cycle sum that is not linear in the integrands breaks the chain rule the
    point-by-point build relies on: it says so by returning None."""
    b = ocp.transcription.blocks
    bent = dataclasses.replace(b, f_s=b.f_s + b.s[0, 0] ** 2)
    assert _block_derivatives(ocp.nlp, bent) is None
    crossed = dataclasses.replace(b, f_s=b.f_s + b.s[1, 0] * ocp.nlp["x"][0])
    assert _block_derivatives(ocp.nlp, crossed) is None
