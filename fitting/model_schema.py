"""Validation of a decoded power-model file (docs/schemas.md §3) into a
:class:`~fitting.power_model.PowerModel`, every error naming the file and field."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from fitting.power_model import (
    READ_VERSIONS,
    SCHEMA_NAME,
    UNITS,
    PowerModel,
    is_finite_number,
)
from kernel.errors import InputError

_REQUIRED_KEYS = (
    "schema",
    "schema_version",
    "name",
    "terms",
    "coefficients",
    "covariance",
    "nominal_power_w",
    "domain",
    "masking",
    "statistics",
    "provenance",
)
_OPTIONAL_KEYS = ("units", "sign_convention")
#: Keys from version 2 on.
_V2_KEYS = ("drive",)
#: Keys from version 3 on.
_V3_KEYS = ("thermal",)
#: Relative tolerance for the derived SI set agreeing with the rpm set on load.
_SI_RTOL = 1e-9


def reject_constant(name: str) -> float:
    raise ValueError(f"non-finite number {name}")


class _Fields:
    """Checks of a model file's fields, each error naming the file and the field.

    Parameters
    ----------
    path : str or Path or None
        The file, named in errors.
    n : int
        Terms of the model: the length of its vectors and matrices.
    """

    def __init__(self, path: str | Path | None, n: int = 0) -> None:
        self.path = path
        self.n = n

    def bad(self, field: str, problem: str, expected: str | None = None) -> InputError:
        """The error of one field."""
        return InputError(self.path, f"field {field!r}: {problem}", expected=expected)

    def vector(self, field: str, value: Any) -> list[float]:
        """``value`` as n finite numbers."""
        n = self.n
        if not isinstance(value, list) or len(value) != n:
            length = len(value) if isinstance(value, list) else type(value).__name__
            raise self.bad(field, f"has {length} entries", f"a list of {n} numbers (one per term)")
        for k, v in enumerate(value):
            if not is_finite_number(v):
                raise self.bad(f"{field}[{k}]", f"{v!r} is not a finite number",
                               "a finite number")
        return [float(v) for v in value]

    def matrix(self, field: str, value: Any) -> list[list[float]]:
        """``value`` as an n x n matrix of finite numbers."""
        if not isinstance(value, list) or len(value) != self.n:
            raise self.bad(field, "wrong shape", f"a {self.n} x {self.n} matrix")
        return [self.vector(f"{field}[{r}]", row) for r, row in enumerate(value)]


def _check_keys(data: dict, fields: _Fields) -> int:
    """Schema, version, the required keys, no unknown one, the units; the version."""
    bad = fields.bad
    if data.get("schema") != SCHEMA_NAME:
        raise bad("schema", f"unknown schema {data.get('schema')!r}", repr(SCHEMA_NAME))
    version = data.get("schema_version")
    if version not in READ_VERSIONS or isinstance(version, bool):
        raise bad("schema_version", f"unsupported version {version!r}",
                  " or ".join(map(str, READ_VERSIONS)))
    required = (_REQUIRED_KEYS + (_V2_KEYS if version >= 2 else ())
                + (_V3_KEYS if version >= 3 else ()))
    for key in required:
        if key not in data:
            raise bad(key, "missing", "all of " + ", ".join(required))
    for key in data:
        if key not in required and key not in _OPTIONAL_KEYS:
            later = (" (a version-2 field in a version-1 file)" if key in _V2_KEYS
                     else " (a version-3 field in an older file)" if key in _V3_KEYS else "")
            raise bad(key, "unknown field" + later)
    if "units" in data and data["units"] != UNITS:
        raise bad("units", f"unsupported units {data['units']!r}", json.dumps(UNITS))
    if not isinstance(data["name"], str):
        raise bad("name", "not a string", "a string")
    return version


def _check_terms(terms: Any, fields: _Fields) -> None:
    """A non-empty list of distinct pairs of exponents >= 0."""
    bad = fields.bad
    if not isinstance(terms, list) or not terms:
        raise bad("terms", "not a non-empty list", "a list of [speed exponent, torque exponent]")
    for k, t in enumerate(terms):
        if (
            not isinstance(t, list)
            or len(t) != 2
            or not all(isinstance(e, int) and not isinstance(e, bool) for e in t)
        ):
            raise bad(f"terms[{k}]", f"{t!r} is not a pair of integers", "[i, j] integers")
        if t[0] < 0 or t[1] < 0:
            raise bad(f"terms[{k}]", f"negative exponent in {t!r}", "exponents >= 0")
    if len({tuple(t) for t in terms}) != len(terms):
        raise bad("terms", "duplicate term")


def _numbers(data: dict, fields: _Fields) -> tuple:
    """The coefficients (rpm, SI) and the covariance (rpm, SI; None when null)."""
    coefs = data["coefficients"]
    if not isinstance(coefs, dict) or set(coefs) != {"rpm", "si"}:
        raise fields.bad("coefficients", "not an object with exactly 'rpm' and 'si'",
                         '{"rpm", "si"}')
    c_rpm = fields.vector("coefficients.rpm", coefs["rpm"])
    c_si = fields.vector("coefficients.si", coefs["si"])
    cov_rpm = cov_si = None
    cov = data["covariance"]
    if cov is not None:
        if not isinstance(cov, dict) or set(cov) != {"rpm", "si"}:
            raise fields.bad("covariance", "not null or an object with 'rpm' and 'si'",
                             '{"rpm", "si"}')
        cov_rpm = fields.matrix("covariance.rpm", cov["rpm"])
        cov_si = fields.matrix("covariance.si", cov["si"])
    return c_rpm, c_si, cov_rpm, cov_si


#: a thermal network's resistances sum to its total within this share
_R_RTOL = 1e-3


def _check_thermal(thermal: dict, fields: _Fields) -> None:
    """A thermal model with a finite positive resistance, time constant and capacitance,
    (when it states them) modes and ladder nodes with positive elements, one per node,
    whose resistances sum to the total, and a positive copper coefficient."""
    for key in ("r_th_k_per_w", "tau_th_s", "c_th_j_per_k"):
        _positive(thermal, key, "thermal", fields)
    nodes = thermal.get("nodes", 1)
    for part, keys in (("modes", ("r_k_per_w", "tau_s")), ("ladder", ("c_j_per_k", "r_k_per_w"))):
        if part not in thermal:
            continue
        if not isinstance(thermal[part], list) or len(thermal[part]) != nodes:
            raise fields.bad(f"thermal.{part}", f"not a list of {nodes} nodes",
                             "one entry per node (thermal.nodes)")
        for k, node in enumerate(thermal[part]):
            for key in keys:
                _positive(node, key, f"thermal.{part}[{k}]", fields)
        total, r_th = sum(node["r_k_per_w"] for node in thermal[part]), thermal["r_th_k_per_w"]
        if abs(total - r_th) > _R_RTOL * r_th:  # a Foster or Cauer network keeps the sum
            raise fields.bad(f"thermal.{part}", f"its resistances sum to {total:.6g} K/W, "
                             f"r_th_k_per_w is {r_th:.6g} K/W", "the network's resistances "
                             f"summing to r_th_k_per_w (within {100 * _R_RTOL:g} %)")
    k = thermal.get("copper_temp_coeff_per_k")
    if k is not None and (not is_finite_number(k) or k <= 0):
        raise fields.bad("thermal.copper_temp_coeff_per_k", f"{k!r}: a copper winding's "
                         "resistance rises with its temperature", "a finite number > 0 "
                         "[1/K] (copper: 0.00393 at 20 degC)")


def _positive(block: dict, key: str, where: str, fields: _Fields) -> None:
    value = block.get(key) if isinstance(block, dict) else None
    if not is_finite_number(value) or value <= 0:
        raise fields.bad(f"{where}.{key}", f"{value!r}: a thermal model needs a positive "
                         "resistance, time constant and capacitance", "a finite number > 0")


def power_model_from_dict(data: Any, path: str | Path | None = None) -> PowerModel:
    """Validate a decoded power-model file and build the :class:`PowerModel`.

    Parameters
    ----------
    data : object
        The decoded JSON document.
    path : str or Path, optional
        The file it came from, named in errors.

    Raises
    ------
    InputError
        Unknown schema or version, missing or unknown fields, wrong shapes,
        non-finite numbers, negative exponents, inconsistent SI coefficients.
    """
    if not isinstance(data, dict):
        raise InputError(path, "top level is not a JSON object", expected="a power model object")
    fields = _Fields(path)
    version = _check_keys(data, fields)
    terms = data["terms"]
    _check_terms(terms, fields)
    fields.n = len(terms)
    c_rpm, c_si, cov_rpm, cov_si = _numbers(data, fields)
    nominal = data["nominal_power_w"]
    if not is_finite_number(nominal) or nominal <= 0:
        raise fields.bad("nominal_power_w", f"{nominal!r}", "a finite positive power [W]")
    for key in ("domain", "masking", "statistics", "provenance",
                *(_V2_KEYS if version >= 2 else ()), *(_V3_KEYS if version >= 3 else ())):
        if data[key] is not None and not isinstance(data[key], dict):
            raise fields.bad(key, "not an object", "an object or null")
    if data.get("thermal") is not None:
        _check_thermal(data["thermal"], fields)
    try:
        model = PowerModel(
            terms=tuple(tuple(t) for t in terms),
            coefficients_rpm=tuple(c_rpm),
            covariance_rpm=None if cov_rpm is None else tuple(tuple(r) for r in cov_rpm),
            nominal_power_w=nominal,
            name=data["name"],
            domain=data["domain"],
            masking=data["masking"],
            statistics=data["statistics"],
            provenance=data["provenance"],
            drive=data.get("drive"),
            thermal=data.get("thermal"),
        )
    except ValueError as exc:
        raise InputError(path, str(exc)) from exc
    if not np.allclose(model.coefficients_si, c_si, rtol=_SI_RTOL, atol=0.0):
        raise fields.bad("coefficients.si", "does not match coefficients.rpm converted to "
                         "rad/s", "c_si = c_rpm * (60 / (2 pi))**i")
    if cov_rpm is not None and not np.allclose(
        np.array(model.covariance_si), np.array(cov_si), rtol=_SI_RTOL, atol=0.0
    ):
        raise fields.bad("covariance.si", "does not match covariance.rpm converted to rad/s")
    return model
