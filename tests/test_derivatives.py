"""The NLP's derivatives built point by point equal those of the whole NLP."""

import dataclasses

import casadi as ca
import numpy as np
import pytest

from optimize.model.kite_model import kite_dae
from optimize.problem.ocp import build_ocp
from optimize.problem.options import Discretization, OcpOptions
from optimize.problem.transcriptions.derivatives import (
    _block_derivatives,
    nlp_derivatives,
    whole_derivatives,
)
from optimize.system.drive_in_force import drive_in_force
from optimize.system.system_file import load_system

N = 6  # intervals: every kind of row and variable, small enough to differentiate whole


def _ocp(solver: str):
    """The shipped system with its drive's limits and an RMS-torque rating (a row on a
    cycle sum), transcribed for ``solver``."""
    system = load_system()
    drive, _ = drive_in_force(system)
    flown = system.in_force(drive)
    flown = dataclasses.replace(flown, drive=dataclasses.replace(
        flown.drive, continuous_torque_nm=0.5 * flown.drive.max_torque_nm))
    options = OcpOptions(Discretization(n_intervals=N)).replace(solver={"solver": solver})
    return build_ocp(kite_dae(*system.model_params()), drive.power_model, options, system=flown)


@pytest.fixture(scope="module")
def ocp():
    return _ocp("ipopt")


def _point(ocp, seed: int = 3):
    """Scaled variables of order one, every weight on, multipliers at random."""
    rng = np.random.default_rng(seed)
    lay = ocp.layout
    return (1.0 + 0.1 * rng.normal(size=lay.n_w),
            ocp.params(7.0, {"p_elec_w": 1.0, "p_mech_w": 0.4}, w_track=0.3, w_fict=0.2),
            rng.normal(size=lay.n_g))


def _assert_same(new, ref, name: str) -> None:
    """Same sparsity, same values (1e-12 of the largest entry), NaN where NaN."""
    assert ca.DM(new).nnz() == ca.DM(ref).nnz(), name
    a, b = _dense(new), _dense(ref)
    finite = np.isfinite(b)
    assert np.array_equal(finite, np.isfinite(a)), name
    assert np.abs(a[finite] - b[finite]).max() <= 1e-12 * np.abs(b[finite]).max(), name


def _dense(value) -> np.ndarray:
    return np.array(ca.densify(ca.DM(value)))


def test_point_by_point_equals_whole_nlp(ocp):
    """Gradient, Jacobian and Hessian agree entry by entry (1e-12 of the largest
    entry) with the same sparsity, at a point with every homotopy weight on."""
    assert ocp.transcription.blocks is not None
    assert ocp.layout.rows_of("rms_torque").size == 1
    x, p, lam_g = _point(ocp)
    blocks = nlp_derivatives(ocp.transcription)
    whole = whole_derivatives(ocp.nlp).functions("ipopt")
    for name, args in (("grad_f", (x, p)), ("jac_g", (x, p)), ("hess_lag", (x, p, 1.3, lam_g))):
        new, ref = blocks[name](*args), whole[name](*args)
        new, ref = (new, ref) if isinstance(ref, (list, tuple)) else ([new], [ref])
        for a, b in zip(new, ref, strict=True):
            _assert_same(a, b, name)


def test_fatrop_format_on_the_stage_layout_equals_the_full_hessian():
    """On the stage-wise layout (running torque integral as a state), the fatrop format
    point by point against CasADi's full Hessian and Lagrangian gradient of the whole NLP."""
    ocp = _ocp("fatrop")
    assert ocp.layout.name == "stagewise" and ocp.transcription.blocks is not None
    x, p, lam_g = _point(ocp, seed=5)
    nlp = ocp.nlp
    lf, lg = ca.SX.sym("lf"), ca.SX.sym("lg", nlp["g"].numel())
    hess, grad = ca.hessian(lf * nlp["f"] + ca.dot(lg, nlp["g"]), nlp["x"])
    ref = ca.Function("ref", [nlp["x"], nlp["p"], lf, lg], [grad, hess])(x, p, 0.7, lam_g)
    new = nlp_derivatives(ocp.transcription, "fatrop")["nlp_hess_l"](x, p, 0.7, lam_g)
    for a, b, name in zip(new, ref, ("grad_gamma_x", "hess_gamma_x_x"), strict=True):
        _assert_same(a, b, name)


def test_sums_not_linear_in_the_integrands_fall_back_to_the_whole_nlp(ocp):
    """A cycle sum that is not linear in the integrands breaks the chain rule the
    point-by-point build relies on: it says so by returning None."""
    b = ocp.transcription.blocks
    bent = dataclasses.replace(b, f_s=b.f_s + b.s[0, 0] ** 2)
    assert _block_derivatives(ocp.nlp, bent) is None
    crossed = dataclasses.replace(b, f_s=b.f_s + b.s[1, 0] * ocp.nlp["x"][0])
    assert _block_derivatives(ocp.nlp, crossed) is None
