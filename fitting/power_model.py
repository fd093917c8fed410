"""The drive power model: a polynomial in drum speed and torque (paper eq. 4 generalised)::

    P_elec [W] = sum_k c_k * speed**i_k * torque**j_k

with term ``(i, j)`` meaning ``speed**i * torque**j``, speed in rpm for the
``rpm`` coefficient set and in rad/s for the ``si`` set, torque in N m, both in
the drum frame (reel-out = negative speed, torque >= 0). Positive power is drawn
from the grid; generated power is negative.

The ``rpm`` coefficients are authoritative; the ``si`` set is derived
(``c_si = c_rpm * (60 / (2 pi))**i``). :class:`PowerModel` evaluates with numpy
and, for the optimal control problem, as a CasADi expression
(:mod:`fitting.power_model_casadi`); the file it is stored in is
:mod:`fitting.model_schema` (validation) and :mod:`fitting.model_file` (reading,
writing), docs/schemas.md §3.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from fitting.terms import Term, powers
from kernel.display import html_view, text_view
from kernel.drive import Drive, dict_problem
from kernel.thermal_model import ThermalModel
from kernel.units import RPM_PER_RAD_S

SCHEMA_NAME = "drivebench.power_model"
#: Version written; 2 added the ``drive`` object (rating and limits of the drive), 3 the
#: ``thermal`` object (the winding's thermal model, or null: fitting/thermal.py).
SCHEMA_VERSION = 3
#: Versions read: a version-1 file loads with ``drive = None``, 1 and 2 with ``thermal = None``.
READ_VERSIONS = (1, 2, 3)


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

_QUADRANTS = ("motor", "generator")
#: the copper loss's term: torque squared (speed power 0, torque power 2)
COPPER_TERM = (0, 2)
#: the term that holds the mechanical power ``(pi / 30) n T`` (speed in rpm)
MECHANICAL_TERM = (1, 1)


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
        Nominal power of the drive [W], the scale of the fit statistics: with a ``drive``,
        its rating's (the file states it twice, ``nominal_power_w`` and
        ``drive.nominal_power_w``, one value: they may differ by rounding alone, and the
        rating's is kept). Read it here.
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
    drive : kernel.drive.Drive or None
        The drive's rating (given as a :class:`kernel.drive.Drive` or its dict form,
        :meth:`kernel.drive.Drive.to_dict`); its nominal power is ``nominal_power_w``.
        None for a version-1 file.
    thermal : kernel.thermal_model.ThermalModel or None
        The winding's fitted thermal model (:func:`fitting.thermal.fit_thermal`; given as
        a :class:`kernel.thermal_model.ThermalModel` or its dict form, docs/schemas.md §3);
        None when the bench logged no winding temperature (or before version 3).
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
    drive: Drive | None = None
    thermal: ThermalModel | None = None

    def __post_init__(self) -> None:
        terms = tuple(Term(t) for t in self.terms)
        coefs = tuple(float(c) for c in self.coefficients_rpm)
        object.__setattr__(self, "terms", terms)
        object.__setattr__(self, "coefficients_rpm", coefs)
        if self.covariance_rpm is not None:
            cov = tuple(tuple(float(v) for v in row) for row in self.covariance_rpm)
            object.__setattr__(self, "covariance_rpm", cov)
        object.__setattr__(self, "nominal_power_w", float(self.nominal_power_w))
        if isinstance(self.drive, dict):
            problem = dict_problem(self.drive)
            if problem is not None:
                raise ValueError(f"invalid PowerModel: {problem}")
            object.__setattr__(self, "drive", Drive.from_dict(self.drive, rating=True))
        if self.thermal is not None and not isinstance(self.thermal, ThermalModel):
            try:
                object.__setattr__(self, "thermal", ThermalModel.from_dict(self.thermal))
            except ValueError as exc:
                raise ValueError(f"invalid PowerModel: {exc}") from None
        problem = model_problem(self)
        if problem is not None:
            raise ValueError(f"invalid PowerModel: {problem}")
        if self.drive is not None:  # one value: the rating's (equal to 1e-12, checked)
            object.__setattr__(self, "nominal_power_w", float(self.drive.nominal_power_w))

    # ------------------------------------------------------------------- views
    @property
    def coefficients(self) -> dict[Term, float]:
        """Term -> coefficient [W per rpm**i (N m)**j] (``{1: 288.2, w^2: ...}``)."""
        return dict(zip(self.terms, self.coefficients_rpm, strict=True))

    @property
    def copper_w_per_nm2(self) -> float:
        """The copper loss's coefficient, the ``T^2`` term's [W/(N m)^2] (0 without it): the
        part of the losses that follows the winding's temperature (its thermal model)."""
        return self.coefficients.get(COPPER_TERM, 0.0)

    def _view_rows(self) -> list[tuple[str, object]]:
        quadrants = ", ".join(self.domain) if self.domain else "none recorded"
        resid = ((self.statistics or {}).get("residuals") or {}).get("all") or {}
        rows = [("terms (rpm, N m -> W)", ", ".join(f"{t!r}: {c:.5g}"
                                                    for t, c in self.coefficients.items())),
                ("nominal power", f"{self.nominal_power_w:g} W"),
                ("covariance", "yes" if self.covariance_rpm is not None else "none"),
                ("validity domain", quadrants)]
        if self.drive is not None:
            rows.append(("drive", self.drive.box_text()))
        if resid.get("std_w") is not None:
            rows.append(("residual std", f"{resid['std_w']:.1f} W"))
        return rows

    def __repr__(self) -> str:
        return text_view(f"PowerModel {self.name!r}", self._view_rows())

    def _repr_html_(self) -> str:
        return html_view(f"PowerModel {self.name!r}", self._view_rows())

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
        from fitting.power_model_casadi import evaluate

        return evaluate(self.terms, self.coefficients_rpm, speed_rpm, torque_nm)

    def casadi_p_elec_w_si(self, speed_rad_s: Any, torque_nm: Any) -> Any:
        """Electrical power [W] as a CasADi expression of speed [rad/s] and torque [N m]."""
        from fitting.power_model_casadi import evaluate

        return evaluate(self.terms, self.coefficients_si, speed_rad_s, torque_nm)

    # ------------------------------------------------------------- its bands
    def basis(self, speed_rpm: Any, torque_nm: Any) -> np.ndarray:
        """The model's basis functions at drum speed [rpm] and torque [N m], one row per
        term (``speed**i * torque**j``) [rpm^i N m^j]: the power is linear in them,
        ``P_elec = coefficients . basis`` (:meth:`of_basis`), so a cycle's average or a
        window's energy is the model applied to the basis's average or integral."""
        speed, torque = np.asarray(speed_rpm, float), np.asarray(torque_nm, float)
        return np.array([speed**i * torque**j for i, j in self.terms])

    def of_basis(self, basis: Any) -> Any:
        """The model's value at basis values ``basis`` (the last axis one per term, e.g. a
        cycle's averages of :meth:`basis` [W], or their integrals over a window [J])."""
        return np.asarray(basis, float) @ np.asarray(self.coefficients_rpm, float)

    def sigma_of_basis(self, basis: Any) -> float:
        """The standard uncertainty of :meth:`of_basis` at one vector of basis values from the
        coefficient covariance, ``sqrt(g^T Sigma g)`` (in the unit of :meth:`of_basis`); 0
        without a covariance. Also of any linear function ``g . coefficients`` (an AEP's
        gradient along a power curve)."""
        if self.covariance_rpm is None:
            return 0.0
        g = np.asarray(basis, float)
        return float(math.sqrt(max(float(g @ np.asarray(self.covariance_rpm, float) @ g), 0.0)))

    # ------------------------------------------------------- another rating
    def carried(self, speed_ratio: float, torque_ratio: float, loss_ratio: float = 1.0,
                **changes: Any) -> PowerModel:
        """This model at the corresponding points of a drive ``speed_ratio`` (``k_n``) times
        its speed and ``torque_ratio`` (``k_T``) times its torque, its losses ``loss_ratio``
        (``lam``) times the similarity law's (the law and its reasons:
        :func:`optimize.model.drivetrain.carry_power_model`).

        Each coefficient ``c_ij -> k_n^(1-i) k_T^(1-j) (lam c_ij + (1 - lam) m_ij)``, ``m``
        the mechanical power's (``pi / 30`` in the ``n T`` term, rpm); the covariance by
        ``lam^2`` and those factors; the validity domain by ``k_n`` in speed and ``k_T`` in
        torque; ``changes`` (name, rating, nominal power, provenance, thermal model, ...)
        as given.

        Raises
        ------
        ValueError
            ``loss_ratio`` other than 1 for a model without the ``n T`` term that holds the
            mechanical power.
        """
        k_n, k_t, lam = float(speed_ratio), float(torque_ratio), float(loss_ratio)
        terms = [tuple(term) for term in self.terms]
        if lam != 1.0 and MECHANICAL_TERM not in terms:
            raise ValueError(f"{self.name}: no speed x torque term holds the mechanical power, "
                             "so its losses cannot be scaled apart from it")
        f = np.array([k_n ** (1 - i) * k_t ** (1 - j) for i, j in terms])
        mech = np.array([1.0 / RPM_PER_RAD_S if term == MECHANICAL_TERM else 0.0
                         for term in terms])
        coefficients = tuple(f * (lam * np.array(self.coefficients_rpm) + (1.0 - lam) * mech))
        cov = None
        if self.covariance_rpm is not None:
            cov = tuple(map(tuple, np.array(self.covariance_rpm) * np.outer(lam * f, lam * f)))
        domain = None
        if self.domain is not None:
            domain = {q: [[n * k_n, t * k_t] for n, t in poly] for q, poly in self.domain.items()}
        return dataclasses.replace(self, coefficients_rpm=coefficients, covariance_rpm=cov,
                                   domain=domain, **changes)

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
            "drive": None if self.drive is None else self.drive.to_dict(),
            "thermal": None if self.thermal is None else self.thermal.to_dict(),
        }

    @property
    def sha256(self) -> str:
        """SHA-256 (hex) of the canonical JSON of :meth:`to_dict` (sorted keys, no spaces)."""
        return hashlib.sha256(_canonical_json(self.to_dict()).encode("utf-8")).hexdigest()

    def summary(self) -> dict:
        """The model as a fit summary names it: name, SHA-256, terms, coefficients."""
        return {"name": self.name, "sha256": self.sha256,
                "terms": [list(t) for t in self.terms],
                "coefficients_rpm": list(self.coefficients_rpm),
                "coefficients_si": list(self.coefficients_si)}


# --------------------------------------------------------------------- helpers
def _canonical_json(data: dict) -> str:
    return json.dumps(data, sort_keys=True, separators=(",", ":"), allow_nan=False)


def _evaluate_np(terms, coefs, speed, torque) -> np.ndarray:
    speed = np.asarray(speed, dtype=float)
    torque = np.asarray(torque, dtype=float)
    sp = powers(speed, max(i for i, _ in terms), np.ones_like(speed))
    tq = powers(torque, max(j for _, j in terms), np.ones_like(torque))
    total = np.zeros(np.broadcast_shapes(speed.shape, torque.shape))
    for (i, j), c in zip(terms, coefs, strict=True):
        total = total + c * sp[i] * tq[j]
    return total


def is_finite_number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)


#: relative tolerance of the covariance checks (asymmetry, negative eigenvalues of the
#: correlation matrix): rounding in a fit or a JSON round trip stays far below it
COVARIANCE_RTOL = 1e-6


def covariance_problem(cov: np.ndarray, terms) -> str | None:
    """What keeps ``cov`` from being a covariance matrix (None: it is one).

    A covariance is symmetric and positive semi-definite: no negative variance,
    and the correlation matrix ``C_ij / sqrt(C_ii C_jj)`` has no eigenvalue below
    ``-COVARIANCE_RTOL`` (a zero variance needs zero covariances in its row).
    """
    scale = float(np.max(np.abs(cov))) if cov.size else 0.0
    if scale == 0.0:
        return None
    asym = np.abs(cov - cov.T)
    if np.max(asym) > COVARIANCE_RTOL * scale:
        i, j = np.unravel_index(int(np.argmax(asym)), cov.shape)
        return f"not symmetric (entry [{i}][{j}] {cov[i, j]:.6g}, [{j}][{i}] {cov[j, i]:.6g})"
    var = np.diag(cov)
    if np.any(var < 0):
        k = int(np.argmin(var))
        return (f"negative variance {var[k]:.6g} of term {list(terms[k])} (entry [{k}][{k}]): "
                "not a covariance")
    sd = np.sqrt(var)
    for k in np.flatnonzero(sd == 0):
        if np.any(np.abs(cov[k]) > COVARIANCE_RTOL * scale):
            return f"zero variance of term {list(terms[k])} with non-zero covariances"
    keep = sd > 0
    corr = cov[np.ix_(keep, keep)] / np.outer(sd[keep], sd[keep])
    low = float(np.min(np.linalg.eigvalsh((corr + corr.T) / 2))) if keep.any() else 0.0
    if low < -COVARIANCE_RTOL:
        return (f"not positive semi-definite (correlation matrix eigenvalue {low:.3g}): "
                "not a covariance")
    return None


def model_problem(model: PowerModel) -> str | None:
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
        problem = covariance_problem(np.array(cov, float), model.terms)
        if problem is not None:
            return f"covariance.rpm: {problem}"
    if not (math.isfinite(model.nominal_power_w) and model.nominal_power_w > 0):
        return "nominal_power_w: a finite positive power [W] expected"
    if not isinstance(model.name, str):
        return "name: a string expected"
    for field in ("domain", "masking", "statistics", "provenance"):
        value = getattr(model, field)
        if value is not None and not isinstance(value, dict):
            return f"{field}: an object or null expected"
    if model.drive is not None:
        problem = (dict_problem(model.drive.to_dict()) if isinstance(model.drive, Drive)
                   else "drive: an object or null expected")
        if problem is not None:
            return problem
        if not math.isclose(model.drive.nominal_power_w, model.nominal_power_w, rel_tol=1e-12):
            return (f"drive.nominal_power_w {model.drive.nominal_power_w!r} differs from "
                    f"nominal_power_w {model.nominal_power_w!r}")
    if model.domain is not None:
        for key, poly in model.domain.items():
            if key not in _QUADRANTS:
                return f"domain: unknown quadrant {key!r}"
            if not isinstance(poly, (list, tuple)) or not all(
                isinstance(p, (list, tuple))
                and len(p) == 2
                and all(is_finite_number(v) for v in p)
                for p in poly
            ):
                return f"domain.{key}: a list of finite [speed_rpm, torque_nm] pairs expected"
    return None
