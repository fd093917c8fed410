"""Power model file: round trip, CasADi = numpy, REFERENCE sanity values, refusals."""

from __future__ import annotations

import json
import math

import casadi as ca
import numpy as np
import pytest

from fitting.model_file import load_power_model, save_power_model
from fitting.power_model import PowerModel
from kernel.errors import InputError
from optimize.paper_model import PAPER_MODEL_PATH, paper_model


def _odd_model() -> PowerModel:
    """A model with an unusual term list (high and mixed orders) and a covariance."""
    terms = ((0, 0), (1, 0), (0, 1), (3, 1), (2, 2), (0, 4), (6, 0), (1, 3))
    rng = np.random.default_rng(7)
    coefs = tuple(rng.normal(size=len(terms)) * 10.0 ** -np.arange(len(terms)))
    a = rng.normal(size=(len(terms), len(terms)))
    cov = a @ a.T * 1e-6
    return PowerModel(
        terms=terms,
        coefficients_rpm=coefs,
        covariance_rpm=tuple(map(tuple, cov)),
        nominal_power_w=8200.0,
        name="odd",
        domain={"motor": [[0.0, 0.0], [1500.0, 0.0], [1500.0, 78.0]]},
        masking={"mech_frac": 0.01},
        statistics={"r2": 0.99},
        provenance={"command_line": ["test"]},
        drive={"nominal_power_w": 8200.0, "max_speed_rpm": 3000.0, "max_torque_nm": 100.0,
               "source": "test"},
    )


def test_reference_sanity_values():
    # docs/paper_figures.md §1: at -1500 rpm, 78 N m the drive delivers 11.04 kW of 12.25 kW
    # shaft power; at -50 rpm, 78 N m it still draws about +279 W. The reference
    # quotes 4 significant digits, hence rtol 1e-3 (and 1 W for the 279 W value).
    m = paper_model()
    assert m.p_elec_w(-1500.0, 78.0) == pytest.approx(-11040.0, rel=1e-3)
    p_mech = -1500.0 * 2 * math.pi / 60 * 78.0
    assert p_mech == pytest.approx(-12250.0, rel=1e-3)
    assert m.p_elec_w(-50.0, 78.0) == pytest.approx(279.0, abs=1.0)
    assert m.nominal_power_w == 8200.0
    assert m.terms == ((0, 0), (2, 0), (0, 2), (1, 1))
    assert PAPER_MODEL_PATH.name == "paper_drive_model.json"


def test_the_model_gives_its_own_band_on_basis_averages():
    """A cycle's average power and its uncertainty from the model's own methods: the average
    of the basis is the average of p_elec_w (the model is linear in it), and the sigma is
    the delta method written out term by term here (rtol 1e-12: rounding)."""
    m = _odd_model()
    rpm, t = np.linspace(-3000, 1500, 9), np.linspace(1, 78, 9)
    basis = m.basis(rpm, t)
    assert basis.shape == (len(m.terms), rpm.size)
    np.testing.assert_allclose(basis[3], rpm**3 * t, rtol=1e-12)  # the term (3, 1)
    g = basis.mean(axis=1)
    assert m.of_basis(g) == pytest.approx(float(np.mean(m.p_elec_w(rpm, t))), rel=1e-12)
    cov = np.array(m.covariance_rpm)
    by_hand = math.sqrt(sum(g[a] * cov[a][b] * g[b] for a in range(len(g))
                            for b in range(len(g))))
    assert m.sigma_of_basis(g) == pytest.approx(by_hand, rel=1e-12)
    assert paper_model().sigma_of_basis(paper_model().basis(-1500.0, 78.0)) == 0.0  # no cov


def test_the_nominal_power_is_one_value_the_ratings():
    """The file states the nominal power twice (top level and the drive's rating): read as
    one value, the rating's, when they differ by rounding; refused when by more (1e-12)."""
    import dataclasses

    m = _odd_model()
    assert m.nominal_power_w == m.drive.nominal_power_w == 8200.0
    rounded = dataclasses.replace(m, nominal_power_w=8200.0 * (1 + 4e-16))
    assert rounded.nominal_power_w == 8200.0 and rounded.to_dict()["nominal_power_w"] == 8200.0
    with pytest.raises(ValueError, match="differs from nominal_power_w"):
        dataclasses.replace(m, nominal_power_w=8200.5)


def test_si_evaluation_equals_rpm_evaluation():
    # Same physical point in both unit systems: must agree to rounding (rtol 1e-12).
    m = _odd_model()
    rpm = np.linspace(-3000, 1500, 7)
    t = np.linspace(0, 78, 7)
    np.testing.assert_allclose(
        m.p_elec_w_si(rpm * 2 * np.pi / 60, t), m.p_elec_w(rpm, t), rtol=1e-12, atol=1e-9
    )
    # covariance transforms like the coefficients: var(c_si) = var(c_rpm) * s**2
    s = (60 / (2 * np.pi)) ** np.array([i for i, _ in m.terms])
    np.testing.assert_allclose(np.diag(m.covariance_si), np.diag(m.covariance_rpm) * s**2,
                               rtol=1e-12)


def test_numpy_broadcasting():
    m = paper_model()
    out = m.p_elec_w(np.array([[-1500.0], [0.0], [1500.0]]), np.array([0.0, 39.0, 78.0]))
    assert out.shape == (3, 3)
    # hand calculation at 0 rpm, 39 N m: a0 + a2 * 39^2
    assert out[1, 1] == pytest.approx(293.5816373499238 + 0.0665919381751 * 39.0**2, rel=1e-14)


@pytest.mark.parametrize("model_fn", [paper_model, _odd_model])
@pytest.mark.parametrize("sym", [ca.SX, ca.MX])
def test_casadi_equals_numpy(model_fn, sym):
    # Independent evaluation paths (numpy arrays vs a CasADi graph); only
    # floating-point rounding differs, so rtol 1e-12.
    m = model_fn()
    w = sym.sym("w")
    t = sym.sym("t")
    f = ca.Function("p", [w, t], [m.casadi_p_elec_w(w, t)])
    rng = np.random.default_rng(0)
    speeds = rng.uniform(-3000, 1500, 50)
    torques = rng.uniform(0, 78, 50)
    got = np.array([float(f(a, b)) for a, b in zip(speeds, torques, strict=True)])
    np.testing.assert_allclose(got, m.p_elec_w(speeds, torques), rtol=1e-12)
    # DM and float inputs work too
    assert float(m.casadi_p_elec_w(ca.DM(-50.0), 78.0)) == pytest.approx(
        float(m.p_elec_w(-50.0, 78.0)), rel=1e-12
    )
    fs = ca.Function("ps", [w, t], [m.casadi_p_elec_w_si(w, t)])
    assert float(fs(-1500 * 2 * np.pi / 60, 78.0)) == pytest.approx(
        float(m.p_elec_w(-1500.0, 78.0)), rel=1e-12
    )


def test_round_trip(tmp_path):
    m = _odd_model()
    path = save_power_model(m, tmp_path / "power_model.json")
    back = load_power_model(path)
    assert back == m
    assert back.sha256 == m.sha256
    data = json.loads(path.read_text())
    assert data["units"]["speed"] == {"rpm": "rpm", "si": "rad/s"}
    assert "negative" in data["sign_convention"]
    assert len(data["coefficients"]["si"]) == len(m.terms)
    assert data["schema_version"] == 3 and data["drive"]["max_speed_rpm"] == 3000.0
    assert data["thermal"] is None
    # no temp files left beside it
    assert [p.name for p in tmp_path.iterdir()] == ["power_model.json"]


def test_sha256_changes_with_content():
    m = paper_model()
    other = PowerModel(
        terms=m.terms,
        coefficients_rpm=(m.coefficients_rpm[0] + 1.0,) + m.coefficients_rpm[1:],
        covariance_rpm=None,
        nominal_power_w=m.nominal_power_w,
        name=m.name,
        domain=m.domain,
        provenance=m.provenance,
    )
    assert len(m.sha256) == 64
    assert other.sha256 != m.sha256


def _paper_dict() -> dict:
    return json.loads(PAPER_MODEL_PATH.read_text())


def _mutations():
    def drop(key):
        def f(d):
            del d[key]
        return f

    def setter(path, value):
        def f(d):
            target = d
            for k in path[:-1]:
                target = target[k]
            target[path[-1]] = value
        return f

    return [
        ("schema", setter(["schema"], "drivebench.something_else")),
        ("schema_version", setter(["schema_version"], 3)),
        ("drive", drop("drive")),
        ("drive.max_speed_rpm", setter(["drive", "max_speed_rpm"], -1500.0)),
        ("drive.nominal_power_w", setter(["drive", "nominal_power_w"], 8000.0)),
        ("drive", setter(["drive", "max_power_w"], 1.0)),
        ("terms", drop("terms")),
        ("coefficients", drop("coefficients")),
        ("nominal_power_w", drop("nominal_power_w")),
        ("provenance", drop("provenance")),
        ("coefficients.rpm", setter(["coefficients", "rpm"], [1.0, 2.0, 3.0])),
        ("coefficients.si", setter(["coefficients", "si"], [1.0, 2.0, 3.0, 4.0])),
        ("terms[1]", setter(["terms", 1], [-2, 0])),
        ("terms[0]", setter(["terms", 0], [0, 0.5])),
        ("terms[2]", setter(["terms", 2], [0, 2, 1])),
        ("covariance", setter(["covariance"], [[1.0]])),
        ("covariance.rpm", setter(["covariance"], {"rpm": [[1.0] * 4] * 3, "si": [[1.0] * 4] * 4})),
        ("nominal_power_w", setter(["nominal_power_w"], -1.0)),
        ("bogus", setter(["bogus"], 1)),
        ("units", setter(["units"], {"speed": "rad/s", "torque": "N m", "power": "kW"})),
        ("domain", setter(["domain"], [1, 2])),
    ]


@pytest.mark.parametrize("field,mutate", _mutations(), ids=[m[0] for m in _mutations()])
def test_malformed_fields_refused(tmp_path, field, mutate):
    d = _paper_dict()
    mutate(d)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(d))
    with pytest.raises(InputError) as err:
        load_power_model(path)
    msg = err.value.describe()
    assert str(path) in msg
    assert field in msg


def test_version_1_file_loads_without_drive(tmp_path):
    # a file written before the drive rating existed (schema_version 1) still loads,
    # with drive None; a "drive" key in a version-1 file is refused
    d = _paper_dict()
    d["schema_version"] = 1
    del d["drive"]
    path = tmp_path / "v1.json"
    path.write_text(json.dumps(d))
    m = load_power_model(path)
    assert m.drive is None and m.nominal_power_w == 8200.0
    assert m.to_dict()["schema_version"] == 3  # written as the current version
    d["drive"] = _paper_dict()["drive"]
    path.write_text(json.dumps(d))
    with pytest.raises(InputError, match="version-2 field"):
        load_power_model(path)


def test_thermal_block_versions_and_physics(tmp_path):
    # version 3 carries "thermal" (null: no thermal model); version 2 files (the shipped
    # paper model) load with thermal None and refuse the key; a non-positive resistance
    # is refused by name
    d2 = _paper_dict()
    assert d2["schema_version"] == 2 and "thermal" not in d2
    d = {**d2, "schema_version": 3, "thermal": None}
    path = tmp_path / "m.json"
    path.write_text(json.dumps(d2))
    assert load_power_model(path).thermal is None
    path.write_text(json.dumps({**d2, "thermal": None}))
    with pytest.raises(InputError, match="version-3 field"):
        load_power_model(path)
    thermal = {"r_th_k_per_w": 0.05, "tau_th_s": 600.0, "c_th_j_per_k": 12000.0}
    path.write_text(json.dumps({**d, "thermal": thermal}))
    assert load_power_model(path).thermal.to_dict() == thermal
    path.write_text(json.dumps({**d, "thermal": {**thermal, "r_th_k_per_w": -0.05}}))
    with pytest.raises(InputError, match=r"thermal\.r_th_k_per_w.*positive resistance"):
        load_power_model(path)


def test_paper_model_states_its_drive():
    # docs/paper_figures.md §1: 8.2 kW, drive constraints |speed| <= 1500 rpm, torque <= 78 N m
    drive = paper_model().drive
    assert (drive.nominal_power_w, drive.max_speed_rpm, drive.max_torque_nm) == (
        8200.0, 1500.0, 78.0)
    assert "Stuyts" in drive.source


def test_non_finite_refused(tmp_path):
    text = PAPER_MODEL_PATH.read_text().replace("293.5816373499238", "NaN", 1)
    path = tmp_path / "nan.json"
    path.write_text(text)
    with pytest.raises(InputError, match="non-finite"):
        load_power_model(path)
    d = _paper_dict()
    d["coefficients"]["rpm"][0] = 1e400  # json.loads turns this into inf
    path.write_text(json.dumps(d).replace("Infinity", "1e400"))
    with pytest.raises(InputError, match="coefficients.rpm"):
        load_power_model(path)


def test_not_json_and_missing_file_refused(tmp_path):
    path = tmp_path / "broken.json"
    path.write_text('{"schema": "drivebench.power_model",\n  "terms": [[0, 0]')
    with pytest.raises(InputError) as err:
        load_power_model(path)
    assert "not valid JSON" in err.value.describe()
    assert err.value.line == 2
    with pytest.raises(InputError, match="file not found"):
        load_power_model(tmp_path / "nope.json")
    path.write_text("[1, 2]")
    with pytest.raises(InputError, match="not a JSON object"):
        load_power_model(path)


def test_constructor_rejects_bad_model():
    with pytest.raises(ValueError, match="negative"):
        PowerModel(terms=((-1, 0),), coefficients_rpm=(1.0,), covariance_rpm=None,
                   nominal_power_w=1.0, name="x")
    with pytest.raises(ValueError, match="coefficients"):
        PowerModel(terms=((0, 0),), coefficients_rpm=(1.0, 2.0), covariance_rpm=None,
                   nominal_power_w=1.0, name="x")
