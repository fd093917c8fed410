"""The sections of a system file, each declared once (:mod:`kernel.sections`): every key
with its unit (the name's suffix), range, default and meaning; the checks that involve
several keys of a section are its ``problems()``. :func:`kernel.sections.read_section`
reads them, and docs/system_file.md's key tables are rendered from them
(:mod:`optimize.system.system_doc`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from kernel.drive import Drive
from kernel.sections import flag, group, integer, number, text
from optimize.model.aero import SURFACES, force_coefficients
from optimize.model.params import AeroCoefficients

#: coefficients a system file may leave out (0: the paper's kite has none of them)
OPTIONAL_COEFFICIENTS = ("cl_q", "cd_q", "cy_p", "cy_r", "cy_ail", "cl_rud", "cn_ail")
#: what a line's density range [kg/m^3] spans
LINE_DENSITY = "Dyneema 970 kg/m^3, steel 7850 kg/m^3"

_Problems = list[tuple[str, str, str]]
section = dataclass(frozen=True, kw_only=True)


@section
class HeaderSection:
    """``[system]``: what the system is."""

    name: str = text("short name")
    description: str = text("one line", default="")
    paper_system: bool = flag(
        "`true` says this is the system of the paper the product implements (Stuyts et al. "
        "2015: the 7.5 kg HIGHWIND wing with the 8.2 kW drive of its Table I; only the "
        "shipped `highwind.toml` and `highwind_drivetrain.toml` say so). `bench optimize` "
        "compares its results with the paper's statements (`claims.csv`) only for such a "
        "system; for any other, every statement's verdict is `does not apply`, and the "
        "terminal and the report say that the paper comparison does not apply")


@section
class KiteSection:
    """``[kite]``: rigid wing; body axes x forward, y right wing, z down."""

    mass_kg: float = number("mass", lo=0)
    reference_area_m2: float = number("aerodynamic reference area S", lo=0)
    span_m: float = number("reference span b (roll/yaw moments, rate normalisation p b / 2V)",
                           lo=0)
    chord_m: float = number("reference chord c (pitch moment, q c / 2V)", lo=0)
    bridle_offset_m: float = number("bridle point below the CG along body z (0: tether at "
                                    "the CG)", lo=0, lo_strict=False)
    inertia_xx_kg_m2: float = number("principal-axis inertia about body x", lo=0)
    inertia_yy_kg_m2: float = number("principal-axis inertia about body y", lo=0)
    inertia_zz_kg_m2: float = number("principal-axis inertia about body z", lo=0)
    inertia_xz_kg_m2: float = number("product of inertia; the matrix [[xx, 0, xz], [0, yy, "
                                     "0], [xz, 0, zz]] must be positive definite")

    def problems(self) -> _Problems:
        """The inertia matrix positive definite."""
        inertia = np.array([[self.inertia_xx_kg_m2, 0, self.inertia_xz_kg_m2],
                            [0, self.inertia_yy_kg_m2, 0],
                            [self.inertia_xz_kg_m2, 0, self.inertia_zz_kg_m2]])
        if np.min(np.linalg.eigvalsh(inertia)) <= 0:
            return [("inertia_xz_kg_m2", "the inertia matrix is not positive definite",
                     "inertia_xz_kg_m2^2 < inertia_xx_kg_m2 * inertia_zz_kg_m2")]
        return []


@section
class AeroSection:
    """``[aero]``: the coefficients of :class:`AeroCoefficients` and their validity range."""

    coefficients: AeroCoefficients = group(
        AeroCoefficients, kind="coefficient", optional=OPTIONAL_COEFFICIENTS,
        doc="the coefficients of the model above: each a number or a polynomial in alpha")
    alpha_min_deg: float = number("lowest angle of attack the coefficients are valid at; the "
                                  "OCP's bound; reported as `alpha_min`", lo=-90, hi=90,
                                  hi_strict=True, bound="alpha_min")
    alpha_max_deg: float = number("highest angle of attack the coefficients are valid at "
                                  "(above `alpha_min_deg`); the OCP's bound; reported as "
                                  "`alpha_max`", lo=-90, hi=90, hi_strict=True, bound="alpha_max")
    beta_min_deg: float = number("lowest sideslip; the OCP's bound; reported as `beta_min`",
                                 lo=-90, hi=90, hi_strict=True, bound="beta_min")
    beta_max_deg: float = number("highest sideslip (above `beta_min_deg`); the OCP's bound; "
                                 "reported as `beta_max`", lo=-90, hi=90, hi_strict=True,
                                 bound="beta_max")

    def problems(self) -> _Problems:
        """The angle ranges rising; the lift slope positive over alpha's."""
        a_lo, a_hi, b_lo, b_hi = (self.alpha_min_deg, self.alpha_max_deg, self.beta_min_deg,
                                  self.beta_max_deg)
        if not -90 < a_lo < a_hi < 90:
            return [("alpha_max_deg", f"range [{a_lo:g}, {a_hi:g}]",
                     "-90 < alpha_min < alpha_max < 90 deg")]
        if not -90 < b_lo < b_hi < 90:
            return [("beta_max_deg", f"range [{b_lo:g}, {b_hi:g}]",
                     "-90 < beta_min < beta_max < 90 deg")]
        slope = lift_slope(self.coefficients, a_lo, a_hi)
        if slope <= 0:
            return [("cl_alpha", f"the lift slope dC_L/dalpha falls to {slope:.4g} per rad in "
                     f"[{a_lo:g}, {a_hi:g}] deg", "a lift slope > 0 over the alpha range")]
        return []


def lift_slope(coeffs: AeroCoefficients, a_lo_deg: float, a_hi_deg: float) -> float:
    """Smallest lift slope dC_L/dalpha [1/rad] of the clean wing over the alpha range
    (central differences on 51 points; ``cl_alpha`` itself for a linear lift)."""
    if not isinstance(coeffs.cl0, tuple) and not isinstance(coeffs.cl_alpha, tuple):
        return coeffs.cl_alpha
    alpha = np.radians(np.linspace(a_lo_deg, a_hi_deg, 51))
    cl = force_coefficients(alpha, 0.0, (0.0, 0.0, 0.0), coeffs)[0]
    return float(np.min(np.diff(cl) / np.diff(alpha)))


@section
class TetherSection:
    """``[tether]``: the kite sees a quarter of the tether's drag (lumped), or the drag of
    ``drag_elements`` elements with their own apparent wind; the line's mass per length
    (:meth:`line_mass_kg_m`, ``None``: massless).

    The tether-force limit is ``max_force_n``, or the working load of the line
    ``tensile_strength_pa * pi d^2 / 4 / safety_factor``, or the smaller of the two
    when both are given; ``None`` each when the file does not give it.
    """

    diameter_m: float = number("line diameter d", lo=0)
    drag_coefficient: float = number(
        "drag coefficient C_D,t of the line; without `drag_elements` the kite sees a quarter "
        "of the line's drag, `C_D += C_D,t d l / (4 S)`", lo=0, lo_strict=False)
    max_force_n: float | None = number("largest tether tension", lo=0, default=None)
    tensile_strength_pa: float | None = number(
        "the line's breaking stress, with `safety_factor`: the working load "
        "`tensile_strength_pa * pi d^2 / 4 / safety_factor` is a tether-force limit", lo=0,
        default=None)
    safety_factor: float | None = number("the safety factor of the working load, with "
                                         "`tensile_strength_pa`", lo=1, lo_strict=False,
                                         default=None)
    mass_kg_m: float | None = number(
        "the line's mass per length. The line is a straight rod from the winch to the kite's "
        "CG (awebox's model): kinetic energy `m/6 (|v_0|^2 + v_0 . v + |v|^2)` with `v_0` "
        "the reeling speed at the winch, its weight at half the kite's height, and the "
        "momentum of the mass flow through the winch; the kite's equation of motion gains "
        "their Lagrange terms", lo=0, lo_strict=False, default=None, absent="a massless line")
    density_kg_m3: float | None = number(
        "instead of `mass_kg_m`: the line's density, mass per length `density * pi d^2 / 4`",
        lo=100, hi=20000, lo_strict=False, default=None, source=LINE_DENSITY)
    drag_elements: int | None = integer(
        "the line's drag over this many equal elements instead (awebox's `multi` model): "
        "element `k` at `s_k = (k + 1/2)/n` of the way up moves at `s_k v`, sees the wind "
        "and (with `atmosphere = \"isa\"`) the density at its height, drags `C_D,t rho/2 |u| "
        "d L_perp u` with the apparent wind `u` and `L_perp` its length across `u`; the kite "
        "takes the fraction `s_k` of it. In still air with the line across the kite's motion "
        "the sum tends to the lumped quarter (`optimize/model/tether.py`)", lo=1, hi=100,
        default=None, absent="the lumped quarter")

    def problems(self) -> _Problems:
        """Strength and safety factor together; a mass per length or a density, not both."""
        if (self.tensile_strength_pa is None) != (self.safety_factor is None):
            missing = "safety_factor" if self.safety_factor is None else "tensile_strength_pa"
            return [(missing, "missing", "tensile_strength_pa and safety_factor together "
                     "(the working load is strength * pi d^2 / 4 / safety factor)")]
        if self.mass_kg_m is not None and self.density_kg_m3 is not None:
            return [("density_kg_m3", "given with mass_kg_m", "mass_kg_m or density_kg_m3, "
                     "not both")]
        return []

    def line_mass_kg_m(self) -> float | None:
        """The line's mass per length [kg/m]: ``mass_kg_m``, or ``density_kg_m3`` times the
        cross-section ``pi d^2 / 4`` (``None``: a massless line)."""
        if self.density_kg_m3 is not None:
            return self.density_kg_m3 * math.pi * self.diameter_m**2 / 4
        return self.mass_kg_m

    def working_load_n(self) -> float | None:
        """The line's working load [N] from its strength and safety factor (or ``None``)."""
        if self.tensile_strength_pa is None or self.safety_factor is None:
            return None
        area_m2 = math.pi * self.diameter_m**2 / 4
        return self.tensile_strength_pa * area_m2 / self.safety_factor


@section
class WinchSection:
    """``[winch]``: drum and gearbox (motor speed = gear ratio x drum speed), the inertia
    turning at drum speed, the winch's reel limits of every scenario kind (``None``: not
    stated; an unstated inertia is zero, a massless drum, and said so)."""

    drum_radius_m: float = number("drum radius", lo=0)
    gear_ratio: float = number("motor speed / drum speed (1: the motor drives the drum "
                               "shaft); motor torque = drum torque / ratio (lossless gear)",
                               lo=0)
    drum_inertia_kg_m2: float | None = number(
        "inertia of everything turning at drum speed: drum, shaft, gearbox output side", lo=0,
        lo_strict=False, default=None,
        absent="zero (a massless drum), and `bench optimize` says so on its first lines")
    max_reel_acceleration_m_s2: float | None = number(
        "largest tether acceleration |l''| of every scenario kind (the winch's limit, like "
        "the tether force); reported as `reel_acceleration_limit` when the optimum sits on it",
        lo=0, default=None, bound="reel_acceleration_limit",
        absent="only the solver's range of 500 m/s^2")
    max_reel_jerk_m_s3: float | None = number(
        "largest tether jerk |l'''| (the OCP's control, the rate of the reel acceleration) of "
        "every scenario kind: how fast the winch can change its torque; reported as "
        "`reel_jerk_limit`", lo=0, default=None, bound="reel_jerk_limit",
        absent="only the solver's range of 5000 m/s^3")
    max_reel_out_speed_m_s: float | None = number(
        "the winch's largest reel-out speed `l'` in every scenario kind (the drive's speed "
        "limit of the `*-lim` kinds comes on top, the smaller wins); reported as "
        "`reel_out_speed_limit`", lo=0, default=None, bound="reel_out_speed_limit",
        absent="only the solver's range of 100 m/s")
    max_reel_in_speed_m_s: float | None = number(
        "the winch's largest reel-in speed `-l'` in every scenario kind; reported as "
        "`reel_in_speed_limit`", lo=0, default=None, bound="reel_in_speed_limit",
        absent="only the solver's range of 100 m/s")


@section
class WindSection:
    """``[wind]``: profile ``"log"`` (roughness length) or ``"power"`` (exponent); the
    atmosphere ``"constant"`` (the density everywhere) or ``"isa"`` (the density at the
    ground, falling with altitude as in the ISA troposphere)."""

    profile: str = text("`\"log\"`: `w(h) = w_ref ln((h + z0)/z0) / ln(h_ref/z0)`; "
                        "`\"power\"`: `w(h) = w_ref (h/h_ref)^exponent`", choices=("log", "power"))
    reference_height_m: float = number("h_ref, where the scenario's wind speed is given", lo=0)
    roughness_length_m: float | None = number("z0, with `\"log\"` only (required there)", lo=0,
                                              default=None)
    exponent: float | None = number("with `\"power\"` only (required there)", lo=0,
                                    default=None)
    winch_height_m: float = number("height of the winch (model origin) above ground", lo=0,
                                   lo_strict=False)
    air_density_kg_m3: float = number("air density; with `atmosphere = \"isa\"` the density "
                                      "at the ground", lo=0)
    gravity_m_s2: float = number("gravitational acceleration", lo=0)
    atmosphere: str = text(
        "`\"constant\"` (`air_density_kg_m3` at every height) or `\"isa\"`: the ISA "
        "troposphere, `rho(h) = rho0 (1 - L h / T0)^(g / (R L) - 1)` with `T0` 288.15 K, `L` "
        "0.0065 K/m, `R` 287.053 J/(kg K), `g` the file's gravity, `h` above the ground taken "
        "as sea level (awebox's default; `optimize/model/atmosphere.py`), at the kite and at "
        "each tether element", choices=("constant", "isa"), default="constant")

    def problems(self) -> _Problems:
        """The profile's own key given, the other profile's not."""
        log = self.profile == "log"
        mine, other = (("roughness_length_m", "exponent") if log
                       else ("exponent", "roughness_length_m"))
        if getattr(self, mine) is None:
            return [(mine, "missing", "a number")]
        if getattr(self, other) is not None:
            return [(other, f"given with profile = \"{self.profile}\"", f"{mine} only")]
        return []


@section
class BoundsSection:
    """``[bounds]``: the OCP's path and parameter bounds.

    ``surface_max_deg`` bounds every control surface; ``aileron_max_deg``,
    ``elevator_max_deg`` and ``rudder_max_deg`` (optional) bound one surface each instead.
    """

    tether_length_min_m: float = number("shortest tether", lo=0, bound="tether_length_min")
    tether_length_max_m: float = number("longest tether (above `tether_length_min_m`)", lo=0,
                                        bound="tether_length_max")
    period_min_s: float = number("shortest cycle period (a search range: an optimum on it is "
                                 "`bound_limited`; `bench optimize --period-scan` holds the "
                                 "period within it)", lo=0, bound="period_min")
    period_max_s: float = number("longest cycle period (above `period_min_s`)", lo=0,
                                 bound="period_max")
    min_ground_clearance_m: float = number("lowest CG altitude above ground; at least half the "
                                           "span is enforced whatever the file says", lo=0,
                                           lo_strict=False)
    min_airspeed_m_s: float = number("lower airspeed bound", lo=0, lo_strict=False,
                                     bound="airspeed_min")
    max_line_angle_deg: float = number("largest angle between the body z axis and the tether; "
                                       "reported as `line_angle_limit`",
                                       lo=0, hi=90, hi_strict=True, bound="line_angle_limit")
    surface_max_deg: float = number("deflection bound of the three control surfaces (< 90)",
                                    lo=0)
    surface_rate_max_rad_s: float = number("rate bound of the three control surfaces", lo=0)
    max_airspeed_m_s: float | None = number("upper airspeed bound (above `min_airspeed_m_s`)",
                                            lo=0, default=None, absent="none",
                                            bound="airspeed_max")
    max_body_rate_deg_s: float | None = number(
        "each body rate p, q, r within +-this in every kind; reported as `body_rate_limit`",
        lo=0, default=None, absent="the solver's range of 1080 deg/s", bound="body_rate_limit")
    min_tension_n: float | None = number(
        "the tether tension at least this in every kind (a line that must stay taut), below "
        "the tether-force limit; reported as `tension_min`", lo=0, lo_strict=False,
        default=None, absent="tension >= 0", bound="tension_min")
    aileron_max_deg: float | None = number(
        "the aileron's deflection bound alone (< 90), in place of `surface_max_deg` "
        "(awebox's `delta_max` is one value per surface)", lo=0, default=None)
    elevator_max_deg: float | None = number(
        "the elevator's deflection bound alone (< 90), in place of `surface_max_deg`", lo=0,
        default=None)
    rudder_max_deg: float | None = number(
        "the rudder's deflection bound alone (< 90), in place of `surface_max_deg`", lo=0,
        default=None)

    def problems(self) -> _Problems:
        """Each range's top above its bottom; every surface bound below 90 deg."""
        if self.max_airspeed_m_s is not None and self.max_airspeed_m_s <= self.min_airspeed_m_s:
            return [("max_airspeed_m_s", "not above min_airspeed_m_s",
                     "min_airspeed_m_s < max_airspeed_m_s")]
        if self.tether_length_max_m <= self.tether_length_min_m:
            return [("tether_length_max_m", "not above tether_length_min_m",
                     "tether_length_min_m < tether_length_max_m")]
        if self.period_max_s <= self.period_min_s:
            return [("period_max_s", "not above period_min_s", "period_min_s < period_max_s")]
        for name, value in zip(SURFACES, self.surface_bounds_deg(), strict=True):
            if value >= 90:
                key = (f"{name}_max_deg" if getattr(self, f"{name}_max_deg")
                       else "surface_max_deg")
                return [(key, f"{value:g}", "an angle < 90 deg")]
        return []

    def surface_bounds_deg(self) -> tuple[float, float, float]:
        """Deflection bound of each surface [deg], in the order of
        :data:`optimize.model.aero.SURFACES`."""
        own = (self.aileron_max_deg, self.elevator_max_deg, self.rudder_max_deg)
        return tuple(self.surface_max_deg if b is None else b for b in own)


#: the sections of a system file, in the file's order
SECTIONS: dict[str, type] = {
    "system": HeaderSection, "kite": KiteSection, "aero": AeroSection,
    "tether": TetherSection, "winch": WinchSection, "drive": Drive,
    "wind": WindSection, "bounds": BoundsSection,
}
