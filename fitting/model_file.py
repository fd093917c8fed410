"""The drive power model file (docs/schemas.md §3): schema, loader, saver, evaluation.

A power model is a polynomial in drum speed and torque (paper eq. 4 generalised)::

    P_elec [W] = sum_k c_k * speed**i_k * torque**j_k

with term ``(i, j)`` meaning ``speed**i * torque**j``, speed in rpm for the
``rpm`` coefficient set and in rad/s for the ``si`` set, torque in N m, both in
the drum frame (reel-out = negative speed, torque >= 0). Positive power is drawn
from the grid; generated power is negative.

The ``rpm`` coefficients are authoritative; the ``si`` set written beside them
is derived (``c_si = c_rpm * (60 / (2 pi))**i``) and checked on load.
"""

from __future__ import annotations

import hashlib
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import casadi as ca
import numpy as np

from bench.drive import DRIVE_KEYS, OPTIONAL_DRIVE_KEYS
from bench.errors import InputError
from bench.files import write_text_atomic

SCHEMA_NAME = "drivebench.power_model"
#: Version written; 2 added the ``drive`` object (rating and limits of the drive).
SCHEMA_VERSION = 2
#: Versions read: a version-1 file loads with ``drive = None``.
READ_VERSIONS = (1, 2)

#: Path of the paper's Table I model (REFERENCE.md §1) in this schema.
PAPER_MODEL_PATH = Path(__file__).resolve().parent.parent / "optimize" / "data" / (
    "paper_drive_model.json"
)

#: rpm per rad/s: speed_rpm = speed_rad_s * RPM_PER_RAD_S.
RPM_PER_RAD_S = 60.0 / (2.0 * math.pi)

UNITS = {
    "speed": {"rpm": "rpm", "si": "rad/s"},
    "torque": "N m",
    "power": "W",
}

SIGN_CONVENTION = (
    "Positive electrical power is drawn from the grid; generated power is negative. "
    "Drum frame: torque >= 0 (tether pulling), reel-out (generating) is negative speed. "
    "Term [i, j] is speed**i * torque**j."
)

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
#: Keys of version 2 only.
_V2_KEYS = ("drive",)
_QUADRANTS = ("motor", "generator")
#: Relative tolerance for the derived SI set agreeing with the rpm set on load.
_SI_RTOL = 1e-9


@dataclass(frozen=True)
class PowerModel:
    """Polynomial model of the drive's electrical power (paper eq. 4, generalised).

    Parameters
    ----------
    terms : tuple of (int, int)
        Exponents ``(i, j)`` of ``speed**i * torque**j`` per term.
    coefficients_rpm : tuple of float
        One coefficient per term, speed in rpm, torque in N m, power in W.
    covariance_rpm : tuple of tuple of float or None
        Covariance of ``coefficients_rpm`` (n_terms x n_terms), or None.
    nominal_power_w : float
        Nominal power of the drive [W], the scale of the fit statistics.
    name : str
        Human-readable model name.
    domain : dict or None
        Validity domain: ``{"motor": [[speed_rpm, torque_nm], ...], "generator": [...]}``,
        the measured envelope polygon per quadrant (a quadrant not measured is absent).
    masking : dict or None
        The efficiency-map masking settings the fit was made with.
    statistics : dict or None
        Fit statistics (R^2, residuals, ...).
    provenance : dict or None
        Where the model comes from (input hash, command line, source).
    drive : dict or None
        The drive's rating ``{nominal_power_w, max_speed_rpm, max_torque_nm, source}``
        (:class:`bench.drive.DriveRating`); its nominal power equals
        ``nominal_power_w``. None for a version-1 file.
    """

    terms: tuple[tuple[int, int], ...]
    coefficients_rpm: tuple[float, ...]
    covariance_rpm: tuple[tuple[float, ...], ...] | None
    nominal_power_w: float
    name: str
    domain: dict | None = None
    masking: dict | None = None
    statistics: dict | None = None
    provenance: dict | None = None
    drive: dict | None = None

    def __post_init__(self) -> None:
        terms = tuple((int(i), int(j)) for i, j in self.terms)
        coefs = tuple(float(c) for c in self.coefficients_rpm)
        object.__setattr__(self, "terms", terms)
        object.__setattr__(self, "coefficients_rpm", coefs)
        if self.covariance_rpm is not None:
            cov = tuple(tuple(float(v) for v in row) for row in self.covariance_rpm)
            object.__setattr__(self, "covariance_rpm", cov)
        object.__setattr__(self, "nominal_power_w", float(self.nominal_power_w))
        problem = _model_problem(self)
        if problem is not None:
            raise ValueError(f"invalid PowerModel: {problem}")

    # ----------------------------------------------------------------- SI sets
    @property
    def _si_scale(self) -> np.ndarray:
        return np.array([RPM_PER_RAD_S**i for i, _ in self.terms])

    @property
    def coefficients_si(self) -> tuple[float, ...]:
        """Coefficients for speed in rad/s (torque N m, power W)."""
        return tuple(float(v) for v in np.array(self.coefficients_rpm) * self._si_scale)

    @property
    def covariance_si(self) -> tuple[tuple[float, ...], ...] | None:
        """Covariance of :attr:`coefficients_si`, or None."""
        if self.covariance_rpm is None:
            return None
        d = self._si_scale
        cov = np.array(self.covariance_rpm) * np.outer(d, d)
        return tuple(tuple(float(v) for v in row) for row in cov)

    # -------------------------------------------------------------- evaluation
    def p_elec_w(self, speed_rpm: Any, torque_nm: Any) -> np.ndarray:
        """Electrical power [W] at drum speed [rpm] and torque [N m] (numpy, broadcasting)."""
        return _evaluate_np(self.terms, self.coefficients_rpm, speed_rpm, torque_nm)

    def p_elec_w_si(self, speed_rad_s: Any, torque_nm: Any) -> np.ndarray:
        """Electrical power [W] at drum speed [rad/s] and torque [N m] (numpy, broadcasting)."""
        return _evaluate_np(self.terms, self.coefficients_si, speed_rad_s, torque_nm)

    def casadi_p_elec_w(self, speed_rpm: Any, torque_nm: Any) -> Any:
        """Electrical power [W] as a CasADi expression of speed [rpm] and torque [N m].

        Works for SX, MX, DM or plain floats and any term list; each power of
        speed and torque is built once by repeated multiplication.
        """
        return _evaluate_casadi(self.terms, self.coefficients_rpm, speed_rpm, torque_nm)

    def casadi_p_elec_w_si(self, speed_rad_s: Any, torque_nm: Any) -> Any:
        """Electrical power [W] as a CasADi expression of speed [rad/s] and torque [N m]."""
        return _evaluate_casadi(self.terms, self.coefficients_si, speed_rad_s, torque_nm)

    # --------------------------------------------------------------- the file
    def to_dict(self) -> dict:
        """The file content (docs/schemas.md §3) as a JSON-ready dict."""
        cov = None
        if self.covariance_rpm is not None:
            cov = {
                "rpm": [list(row) for row in self.covariance_rpm],
                "si": [list(row) for row in self.covariance_si],
            }
        return {
            "schema": SCHEMA_NAME,
            "schema_version": SCHEMA_VERSION,
            "name": self.name,
            "units": UNITS,
            "sign_convention": SIGN_CONVENTION,
            "terms": [list(t) for t in self.terms],
            "coefficients": {
                "rpm": list(self.coefficients_rpm),
                "si": list(self.coefficients_si),
            },
            "covariance": cov,
            "nominal_power_w": self.nominal_power_w,
            "domain": self.domain,
            "masking": self.masking,
            "statistics": self.statistics,
            "provenance": self.provenance,
            "drive": self.drive,
        }

    @property
    def sha256(self) -> str:
        """SHA-256 (hex) of the canonical JSON of :meth:`to_dict` (sorted keys, no spaces)."""
        return hashlib.sha256(_canonical_json(self.to_dict()).encode("utf-8")).hexdigest()


# --------------------------------------------------------------------- helpers
def _canonical_json(data: dict) -> str:
    return json.dumps(data, sort_keys=True, separators=(",", ":"), allow_nan=False)


def _powers(x: Any, n: int, one: Any) -> list:
    out = [one]
    for _ in range(n):
        out.append(x if len(out) == 1 else out[-1] * x)
    return out


def _evaluate_np(terms, coefs, speed, torque) -> np.ndarray:
    speed = np.asarray(speed, dtype=float)
    torque = np.asarray(torque, dtype=float)
    sp = _powers(speed, max(i for i, _ in terms), np.ones_like(speed))
    tq = _powers(torque, max(j for _, j in terms), np.ones_like(torque))
    total = np.zeros(np.broadcast_shapes(speed.shape, torque.shape))
    for (i, j), c in zip(terms, coefs, strict=True):
        total = total + c * sp[i] * tq[j]
    return total


def _evaluate_casadi(terms, coefs, speed, torque) -> Any:
    sp = _powers(speed, max(i for i, _ in terms), None)
    tq = _powers(torque, max(j for _, j in terms), None)
    total = 0
    for (i, j), c in zip(terms, coefs, strict=True):
        factors = [f for f in (sp[i], tq[j]) if f is not None]
        term = c
        for f in factors:
            term = term * f
        total = total + term
    if isinstance(total, (int, float)):
        return ca.DM(total)
    return total


def _is_finite_number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


def _model_problem(model: PowerModel) -> str | None:
    """Return a description of what is wrong with a model, or None."""
    n = len(model.terms)
    if n == 0:
        return "terms: at least one term expected"
    for i, j in model.terms:
        if i < 0 or j < 0:
            return f"terms: exponent of term [{i}, {j}] is negative"
    if len(set(model.terms)) != n:
        return "terms: duplicate term"
    if len(model.coefficients_rpm) != n:
        return f"coefficients.rpm: {len(model.coefficients_rpm)} values for {n} terms"
    if not all(math.isfinite(c) for c in model.coefficients_rpm):
        return "coefficients.rpm: non-finite value"
    if model.covariance_rpm is not None:
        cov = model.covariance_rpm
        if len(cov) != n or any(len(row) != n for row in cov):
            return f"covariance.rpm: shape is not {n} x {n}"
        if not all(math.isfinite(v) for row in cov for v in row):
            return "covariance.rpm: non-finite value"
    if not (math.isfinite(model.nominal_power_w) and model.nominal_power_w > 0):
        return "nominal_power_w: a finite positive power [W] expected"
    if not isinstance(model.name, str):
        return "name: a string expected"
    for field in ("domain", "masking", "statistics", "provenance", "drive"):
        value = getattr(model, field)
        if value is not None and not isinstance(value, dict):
            return f"{field}: an object or null expected"
    if model.drive is not None:
        for key in (*DRIVE_KEYS, *OPTIONAL_DRIVE_KEYS):
            v = model.drive.get(key)
            if (v is not None or key in DRIVE_KEYS) and not (_is_finite_number(v) and v > 0):
                return f"drive.{key}: a finite positive number expected, got {v!r}"
        if not isinstance(model.drive.get("source", ""), str):
            return "drive.source: a string expected"
        unknown = set(model.drive) - {*DRIVE_KEYS, *OPTIONAL_DRIVE_KEYS, "source"}
        if unknown:
            return f"drive: unknown key {sorted(unknown)[0]!r}"
        if not math.isclose(model.drive["nominal_power_w"], model.nominal_power_w, rel_tol=1e-12):
            return (f"drive.nominal_power_w {model.drive['nominal_power_w']!r} differs from "
                    f"nominal_power_w {model.nominal_power_w!r}")
    if model.domain is not None:
        for key, poly in model.domain.items():
            if key not in _QUADRANTS:
                return f"domain: unknown quadrant {key!r}"
            if not isinstance(poly, (list, tuple)) or not all(
                isinstance(p, (list, tuple))
                and len(p) == 2
                and all(_is_finite_number(v) for v in p)
                for p in poly
            ):
                return f"domain.{key}: a list of finite [speed_rpm, torque_nm] pairs expected"
    return None


# ---------------------------------------------------------------------- loader
def _reject_constant(name: str) -> float:
    raise ValueError(f"non-finite number {name}")


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

    def bad(field: str, problem: str, expected: str | None = None) -> InputError:
        return InputError(path, f"field {field!r}: {problem}", expected=expected)

    if not isinstance(data, dict):
        raise InputError(path, "top level is not a JSON object", expected="a power model object")
    if data.get("schema") != SCHEMA_NAME:
        raise bad("schema", f"unknown schema {data.get('schema')!r}", repr(SCHEMA_NAME))
    version = data.get("schema_version")
    if version not in READ_VERSIONS or isinstance(version, bool):
        raise bad("schema_version", f"unsupported version {version!r}",
                  " or ".join(map(str, READ_VERSIONS)))
    required = _REQUIRED_KEYS + (_V2_KEYS if version >= 2 else ())
    for key in required:
        if key not in data:
            raise bad(key, "missing", "all of " + ", ".join(required))
    for key in data:
        if key not in required and key not in _OPTIONAL_KEYS:
            raise bad(key, "unknown field" + (" (a version-2 field in a version-1 file)"
                                              if key in _V2_KEYS else ""))
    if "units" in data and data["units"] != UNITS:
        raise bad("units", f"unsupported units {data['units']!r}", json.dumps(UNITS))

    if not isinstance(data["name"], str):
        raise bad("name", "not a string", "a string")

    terms = data["terms"]
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
    n = len(terms)

    def vector(field: str, value: Any) -> list[float]:
        if not isinstance(value, list) or len(value) != n:
            length = len(value) if isinstance(value, list) else type(value).__name__
            raise bad(field, f"has {length} entries", f"a list of {n} numbers (one per term)")
        for k, v in enumerate(value):
            if not _is_finite_number(v):
                raise bad(f"{field}[{k}]", f"{v!r} is not a finite number", "a finite number")
        return [float(v) for v in value]

    def matrix(field: str, value: Any) -> list[list[float]]:
        if not isinstance(value, list) or len(value) != n:
            raise bad(field, "wrong shape", f"a {n} x {n} matrix")
        return [vector(f"{field}[{r}]", row) for r, row in enumerate(value)]

    coefs = data["coefficients"]
    if not isinstance(coefs, dict) or set(coefs) != {"rpm", "si"}:
        raise bad("coefficients", "not an object with exactly 'rpm' and 'si'", '{"rpm", "si"}')
    c_rpm = vector("coefficients.rpm", coefs["rpm"])
    c_si = vector("coefficients.si", coefs["si"])

    cov_rpm = None
    cov = data["covariance"]
    if cov is not None:
        if not isinstance(cov, dict) or set(cov) != {"rpm", "si"}:
            raise bad("covariance", "not null or an object with 'rpm' and 'si'", '{"rpm", "si"}')
        cov_rpm = matrix("covariance.rpm", cov["rpm"])
        cov_si = matrix("covariance.si", cov["si"])

    nominal = data["nominal_power_w"]
    if not _is_finite_number(nominal) or nominal <= 0:
        raise bad("nominal_power_w", f"{nominal!r}", "a finite positive power [W]")
    for key in ("domain", "masking", "statistics", "provenance",
                *(_V2_KEYS if version >= 2 else ())):
        if data[key] is not None and not isinstance(data[key], dict):
            raise bad(key, "not an object", "an object or null")

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
        )
    except ValueError as exc:
        raise InputError(path, str(exc)) from exc

    if not np.allclose(model.coefficients_si, c_si, rtol=_SI_RTOL, atol=0.0):
        raise bad("coefficients.si", "does not match coefficients.rpm converted to rad/s",
                  "c_si = c_rpm * (60 / (2 pi))**i")
    if cov_rpm is not None and not np.allclose(
        np.array(model.covariance_si), np.array(cov_si), rtol=_SI_RTOL, atol=0.0
    ):
        raise bad("covariance.si", "does not match covariance.rpm converted to rad/s")
    return model


def load_power_model(path: str | Path) -> PowerModel:
    """Read and validate a power-model file (docs/schemas.md §3).

    Parameters
    ----------
    path : str or Path
        The JSON file.

    Returns
    -------
    PowerModel

    Raises
    ------
    InputError
        If the file is missing, is not JSON, or fails validation; the message
        names the file and the field.
    """
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError as exc:
        raise InputError(path, "file not found", expected="a power model JSON file") from exc
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(path, f"cannot read: {exc}") from exc
    try:
        data = json.loads(text, parse_constant=_reject_constant)
    except json.JSONDecodeError as exc:
        raise InputError(path, f"not valid JSON: {exc.msg}", line=exc.lineno) from exc
    except ValueError as exc:
        raise InputError(path, str(exc), expected="finite numbers only") from exc
    return power_model_from_dict(data, path)


def save_power_model(model: PowerModel, path: str | Path) -> Path:
    """Write ``model`` to ``path`` atomically (temp file in the same dir, then os.replace).

    Parameters
    ----------
    model : PowerModel
    path : str or Path
        Destination JSON file; its directory must exist.

    Returns
    -------
    Path
        The written path.
    """
    path = Path(path)
    text = json.dumps(model.to_dict(), indent=2, allow_nan=False) + "\n"
    return write_text_atomic(path, text)


def paper_model() -> PowerModel:
    """The paper's Table I model (REFERENCE.md §1), as shipped in :data:`PAPER_MODEL_PATH`."""
    return load_power_model(PAPER_MODEL_PATH)
