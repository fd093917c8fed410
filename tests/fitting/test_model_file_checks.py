"""A power-model file with a broken covariance or a non-finite number is refused,
naming the field (fitting/model_file.py)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from drivebench.cli import main
from fitting.model_file import load_power_model
from fitting.power_model import covariance_problem
from kernel.errors import InputError
from optimize.paper_model import PAPER_MODEL_PATH, paper_model

TERMS = paper_model().terms


def _paper_json():
    return json.loads(PAPER_MODEL_PATH.read_text())


def _write(tmp_path, data, name="m.json"):
    path = tmp_path / name
    path.write_text(json.dumps(data, allow_nan=True))
    return path


def _cov(data):
    """A valid covariance for the file (the paper file has none): diag(1, 1e-8, 1e-3, 1e-6)."""
    var = np.array([1.0, 1e-8, 1e-3, 1e-6])
    d = np.array([1.0, (60 / (2 * np.pi)) ** 2, 1.0, 60 / (2 * np.pi)])  # rpm -> rad/s
    return {"rpm": np.diag(var).tolist(), "si": np.diag(var * d * d).tolist()}


def test_valid_covariance_loads(tmp_path):
    data = _paper_json()
    data["covariance"] = _cov(data)
    assert load_power_model(_write(tmp_path, data)).covariance_rpm is not None


@pytest.mark.parametrize(("change", "words"), [
    ("negative", "negative variance -1"),
    ("asymmetric", "not symmetric"),
    ("indefinite", "not positive semi-definite"),
])
def test_broken_covariance_is_refused(tmp_path, change, words, capsys):
    """Negative variances collapse the 95 % band to zero width in aep; an asymmetric or
    indefinite matrix is no covariance either: refused by load (field named), optimize
    and aep's model reader exit 2."""
    data = _paper_json()
    cov = _cov(data)
    rpm, si = np.array(cov["rpm"]), np.array(cov["si"])
    if change == "negative":
        rpm[0, 0], si[0, 0] = -1.0, -1.0
    elif change == "asymmetric":
        rpm[0, 2], si[0, 2] = 0.5, 0.5
    else:  # correlation 2 between terms 0 and 2
        rpm[0, 2] = rpm[2, 0] = si[0, 2] = si[2, 0] = 2 * np.sqrt(1.0 * 1e-3)
    data["covariance"] = {"rpm": rpm.tolist(), "si": si.tolist()}
    path = _write(tmp_path, data)
    with pytest.raises(InputError, match=f"covariance.rpm: {words}"):
        load_power_model(path)
    assert main(["optimize", "--drive-model", str(path), "--wind-grid", "7",
                 "--out", str(tmp_path / "opt")]) == 2
    assert "covariance.rpm" in capsys.readouterr().err


def test_covariance_problem_tolerates_rounding():
    a = np.array([[4.0, 1.0], [1.0, 0.25]])  # correlation exactly 1: PSD (rank 1)
    assert covariance_problem(a * (1 + 1e-12), ((0, 0), (1, 0))) is None


@pytest.mark.parametrize(("where", "field"), [
    (("coefficients", "rpm", 2), "coefficients.rpm[2]"),
    (("nominal_power_w",), "nominal_power_w"),
    (("drive", "max_torque_nm"), "drive.max_torque_nm"),
])
def test_nan_names_the_field(tmp_path, where, field):
    data = _paper_json()
    node = data
    for key in where[:-1]:
        node = node[key]
    if isinstance(node, dict) and where[-1] not in node:
        pytest.skip(f"no {field} in the shipped file")
    node[where[-1]] = float("nan")
    with pytest.raises(InputError) as err:
        load_power_model(_write(tmp_path, data))
    assert err.value.column == field and "non-finite" in err.value.problem
