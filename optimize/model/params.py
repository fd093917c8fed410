"""Physical parameters of the kite, its aerodynamics and the wind (docs/paper_figures.md §2).

Every field carries its unit and source in ``dataclasses.field(metadata=...)``.
``from_dict`` builds a parameter set from a plain mapping and rejects unknown
and missing keys, so a typo in a configuration file cannot silently fall back
to a default.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, TypeVar

_SRC_KITE = "ghorn/rawesome rawe/models/betty_conf.py (docs/paper_figures.md §2)"
_SRC_AERO = ("ghorn/rawesome rawe/models/betty_conf.py; per-degree values times 180/pi "
             "(docs/paper_figures.md §2)")
_SRC_WIND = "ghorn/rawesome rawe/models/crosswind.py wind_shear (docs/paper_figures.md §2)"

_DEG = 180.0 / math.pi  # converts a per-degree derivative into a per-radian one

T = TypeVar("T")


def _f(default: float, unit: str, source: str) -> Any:
    return field(default=default, metadata={"unit": unit, "source": source})


def _from_dict(cls: type[T], data: dict[str, Any]) -> T:
    """Build ``cls`` from ``data``; unknown or missing keys raise ``ValueError``."""
    names = {f.name for f in dataclasses.fields(cls)}
    unknown = sorted(set(data) - names)
    missing = sorted(names - set(data))
    if unknown:
        raise ValueError(f"{cls.__name__}: unknown keys {unknown}; expected {sorted(names)}")
    if missing:
        raise ValueError(f"{cls.__name__}: missing keys {missing}")
    values = {}
    for key, value in data.items():
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ValueError(f"{cls.__name__}: key {key!r} must be a number, got {value!r}")
        values[key] = float(value)
    return cls(**values)


@dataclass(frozen=True)
class KiteParams:
    """Rigid-wing kite, tether and environment constants.

    Body axes: x forward, y right wing, z down. World frame: NED, z down; the
    tether leaves the winch at the origin and attaches at ``[0, 0, zt]`` in
    body axes.
    """

    mass_kg: float = _f(7.5, "kg", _SRC_KITE)
    sref_m2: float = _f(0.684, "m^2", _SRC_KITE)
    bref_m: float = _f(2.904, "m", _SRC_KITE)
    cref_m: float = _f(0.2512, "m", _SRC_KITE)
    zt_m: float = _f(0.10, "m", _SRC_KITE + " (bridle point below the CG)")
    g_m_s2: float = _f(9.81, "m/s^2", _SRC_KITE)
    rho_kg_m3: float = _f(1.23, "kg/m^3", _SRC_KITE)
    j1_kg_m2: float = _f(0.565, "kg m^2", _SRC_KITE)
    j2_kg_m2: float = _f(0.161, "kg m^2", _SRC_KITE)
    j3_kg_m2: float = _f(0.723, "kg m^2", _SRC_KITE)
    j31_kg_m2: float = _f(0.0, "kg m^2", _SRC_KITE)
    tether_cd_per_m: float = _f(
        0.25 * 0.001, "m (C_D_tether * sref / l)",
        "ghorn/rawesome (docs/paper_figures.md §2): C_D += 0.25*l*0.001/sref"
    )
    r_winch_m: float = _f(0.1, "m", "docs/paper_figures.md §1 (winch drum radius)")
    gear_ratio: float = _f(1.0, "-", "docs/paper_figures.md §1 (drive on the drum shaft)")
    drum_inertia_kg_m2: float = _f(0.0, "kg m^2", "the paper's OCP: a massless drum")
    rotor_inertia_kg_m2: float = _f(0.0, "kg m^2", "the paper's OCP: a massless rotor")

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> KiteParams:
        """Build from a mapping with exactly the field names as keys."""
        return _from_dict(cls, data)


@dataclass(frozen=True)
class AeroCoefficients:
    """Aerodynamic coefficients; angles, rates and deflections in radians.

    Each is a number or a polynomial in the angle of attack: a tuple ``(c0, c1, ...)``
    standing for ``c0 + c1 alpha + c2 alpha^2 + ...`` (alpha in rad; evaluated by
    :func:`optimize.model.aero.at_alpha`), as awebox states stability derivatives.
    """

    cl0: float = _f(0.203530, "-", _SRC_AERO)
    cl_alpha: float = _f(5.786876, "1/rad", _SRC_AERO)
    cl_elev: float = _f(-0.0105 * _DEG, "1/rad", _SRC_AERO)
    cd0: float = _f(0.008767, "-", _SRC_AERO)
    cd_alpha: float = _f(0.018751, "1/rad", _SRC_AERO)
    cd_alpha2: float = _f(1.529989, "1/rad^2", _SRC_AERO)
    cd_beta2: float = _f(-0.16247, "1/rad^2", _SRC_AERO)
    cd_elev2: float = _f(4.19816e-05, "1/rad^2", _SRC_AERO + " (applied in rad as written)")
    cd_alpha_elev: float = _f(-9.79647e-05, "1/rad^2", _SRC_AERO + " (in rad as written)")
    cd_elev: float = _f(4.52856e-05, "1/rad", _SRC_AERO + " (in rad as written)")
    cd_ail2: float = _f(5.60583e-05, "1/rad^2", _SRC_AERO + " (in rad as written)")
    cd_beta_ail: float = _f(-6.73139e-06, "1/rad^2", _SRC_AERO + " (in rad as written)")
    cd_rud2: float = _f(2.03105e-05, "1/rad^2", _SRC_AERO + " (in rad as written)")
    cd_beta_rud: float = _f(5.55453e-05, "1/rad^2", _SRC_AERO + " (in rad as written)")
    cy_beta: float = _f(-0.239789, "1/rad", _SRC_AERO)
    cy_rud: float = _f(0.0035 * _DEG, "1/rad", _SRC_AERO)
    cl_p: float = _f(-0.576, "-", _SRC_AERO + " (per p*b/(2v))")
    cl_r: float = _f(0.0707, "-", _SRC_AERO + " (per r*b/(2v))")
    cl_beta: float = _f(-0.051808, "1/rad", _SRC_AERO)
    cl_alpha_beta: float = _f(-0.208344, "1/rad^2", _SRC_AERO)
    cl_ail: float = _f(0.0073 * _DEG, "1/rad", _SRC_AERO)
    cm0: float = _f(0.028980, "-", _SRC_AERO)
    cm_q: float = _f(-15.5, "-", _SRC_AERO + " (per q*c/(2v))")
    cm_alpha: float = _f(-0.450643, "1/rad", _SRC_AERO)
    cm_elev: float = _f(0.0352 * _DEG, "1/rad", _SRC_AERO)
    cn_p: float = _f(-0.036, "-", _SRC_AERO + " (per p*b/(2v))")
    cn_r: float = _f(-0.0667, "-", _SRC_AERO + " (per r*b/(2v))")
    cn_beta: float = _f(0.037183, "1/rad", _SRC_AERO)
    cn_alpha_beta: float = _f(-0.028933, "1/rad^2", _SRC_AERO)
    cn_rud: float = _f(0.001176 * _DEG, "1/rad", _SRC_AERO)
    # derivatives the paper's kite has none of (optional keys of a system file, 0 here)
    cl_q: float = _f(0.0, "-", "none in the paper's model (per q*c/(2v))")
    cd_q: float = _f(0.0, "-", "none in the paper's model (per q*c/(2v))")
    cy_p: float = _f(0.0, "-", "none in the paper's model (per p*b/(2v))")
    cy_r: float = _f(0.0, "-", "none in the paper's model (per r*b/(2v))")
    cy_ail: float = _f(0.0, "1/rad", "none in the paper's model")
    cl_rud: float = _f(0.0, "1/rad", "none in the paper's model")
    cn_ail: float = _f(0.0, "1/rad", "none in the paper's model")

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> AeroCoefficients:
        """Build from a mapping with exactly the field names as keys."""
        return _from_dict(cls, data)


@dataclass(frozen=True)
class TetherModel:
    """The tether's mass and how its drag reaches the kite.

    ``drag_elements = 0`` is the lumped model of :class:`KiteParams` (a quarter of
    the line's drag added to the kite's drag coefficient); ``n > 0`` splits the
    straight line into ``n`` elements, each with the apparent wind at its midpoint
    (:mod:`optimize.model.tether`). A zero mass is the massless line.
    """

    mass_kg_m: float = _f(0.0, "kg/m", "the paper's OCP: a massless tether")
    diameter_m: float = _f(0.0, "m", "used by the element drag only")
    drag_coefficient: float = _f(0.0, "-", "used by the element drag only")
    drag_elements: int = _f(0, "-", "0: the lumped drag of KiteParams.tether_cd_per_m")


@dataclass(frozen=True)
class WindModel:
    """Logarithmic wind shear ``w(h) = w_ref ln((h + z0)/z0) / ln(h_ref/z0)``, or with
    ``power_law_exponent = a > 0`` the power law ``w(h) = w_ref (h / h_ref)^a``.

    ``h`` is the altitude above ground; the model origin (winch) sits
    ``origin_altitude_m`` above ground. The wind blows along world +x.
    """

    reference_altitude_m: float = _f(100.0, "m", _SRC_WIND)
    roughness_length_m: float = _f(0.1, "m", _SRC_WIND)
    origin_altitude_m: float = _f(2.0, "m", _SRC_WIND + " (altitude0 = -2)")
    power_law_exponent: float = _f(0.0, "-", "0 selects the log law")
    temperature_lapse_k_m: float = _f(
        0.0, "K/m", "0: a constant air density; 0.0065: the ISA troposphere "
        "(optimize.model.atmosphere)")

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> WindModel:
        """Build from a mapping with exactly the field names as keys."""
        return _from_dict(cls, data)
