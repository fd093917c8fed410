"""The system file of ``bench optimize --system FILE``: kite, aero, tether, winch, drive,
wind and bounds (TOML; docs/system_file.md describes every key).

:func:`load_system` reads and validates a file into a frozen :class:`System`;
every error (unknown or missing key, wrong type, non-physical value such as a
negative mass or an inertia that is not positive definite) is an
:class:`~kernel.errors.InputError` naming the file and the key. The shipped
systems live in ``optimize/data/systems/`` (:func:`shipped_system_path`);
``highwind.toml`` is the paper's kite and the default.

A :class:`System` turns into the model's parameter sets
(:meth:`System.kite_params`, :meth:`System.aero_coefficients`,
:meth:`System.wind_model`), into the drive limits (:meth:`System.drive_limits`)
and into the OCP's options with the file's bounds (:meth:`System.ocp_options`). It
is hashed on its parsed content (:attr:`System.sha256`, comments and key order do
not count), which is part of the NLP cache key and of the stored-guess acceptance.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from kernel.errors import InputError
from kernel.files import parse_toml, read_text
from optimize.model.dae import DaeSpec
from optimize.model.kite_model import kite_dae
from optimize.system.params import AeroCoefficients, KiteParams, WindModel
from optimize.system.plausibility import check_system

#: folder of the shipped system files (package data)
SYSTEMS_DIR = Path(__file__).resolve().parent.parent / "data" / "systems"
DEFAULT_SYSTEM = "highwind"


def shipped_system_path(name: str = DEFAULT_SYSTEM) -> Path:
    """Path of a shipped system file by name (``"highwind"``, ``"ap2"``, ``"megawes"``)."""
    return SYSTEMS_DIR / f"{name}.toml"


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


@dataclass(frozen=True)
class KiteSection:
    """``[kite]``: rigid wing; body axes x forward, y right wing, z down."""

    mass_kg: float
    reference_area_m2: float
    span_m: float
    chord_m: float
    bridle_offset_m: float  # bridle point below the CG along body z [m]
    inertia_xx_kg_m2: float
    inertia_yy_kg_m2: float
    inertia_zz_kg_m2: float
    inertia_xz_kg_m2: float


@dataclass(frozen=True)
class AeroSection:
    """``[aero]``: the coefficients of :class:`AeroCoefficients` and their validity range."""

    coefficients: AeroCoefficients
    alpha_min_deg: float
    alpha_max_deg: float
    beta_min_deg: float
    beta_max_deg: float


@dataclass(frozen=True)
class TetherSection:
    """``[tether]``: the kite sees a quarter of the tether's drag (lumped).

    The tether-force limit is ``max_force_n``, or the working load of the line
    ``tensile_strength_pa * pi d^2 / 4 / safety_factor``, or the smaller of the two
    when both are given; ``None`` each when the file does not give it.
    """

    diameter_m: float
    drag_coefficient: float
    max_force_n: float | None = None
    tensile_strength_pa: float | None = None
    safety_factor: float | None = None

    def working_load_n(self) -> float | None:
        """The line's working load [N] from its strength and safety factor (or ``None``)."""
        if self.tensile_strength_pa is None or self.safety_factor is None:
            return None
        area_m2 = math.pi * self.diameter_m**2 / 4
        return self.tensile_strength_pa * area_m2 / self.safety_factor


@dataclass(frozen=True)
class WinchSection:
    """``[winch]``: drum and gearbox (motor speed = gear ratio x drum speed), the inertia
    turning at drum speed [kg m^2] and the reel-acceleration limit [m/s^2] (``None``: not
    stated; an unstated inertia is zero, a massless drum, and said so)."""

    drum_radius_m: float
    gear_ratio: float
    drum_inertia_kg_m2: float | None = None
    max_reel_acceleration_m_s2: float | None = None


@dataclass(frozen=True)
class DriveSection:
    """``[drive]``: the drive's rating at the motor shaft and where its losses come from
    (resolved by :func:`optimize.system.drive_in_force.drive_in_force`); ``None`` = not stated."""

    max_speed_rpm: float | None
    max_torque_nm: float | None
    nominal_power_w: float | None
    max_p_elec_w: float | None
    continuous_torque_nm: float | None = None
    overload: float | None = None
    losses: str | None = None  # "paper" or a power_model.json path relative to the file
    scaling: str | None = None  # "similarity" or "none"
    source: str | None = None
    rotor_inertia_kg_m2: float | None = None  # at the motor shaft
    base_speed_rpm: float | None = None  # constant power above it
    envelope_speed_rpm: tuple[float, ...] | None = None  # datasheet table, with
    envelope_torque_nm: tuple[float, ...] | None = None  # its largest torques


@dataclass(frozen=True)
class WindSection:
    """``[wind]``: profile ``"log"`` (roughness length) or ``"power"`` (exponent)."""

    profile: str
    reference_height_m: float
    roughness_length_m: float | None
    exponent: float | None
    winch_height_m: float
    air_density_kg_m3: float
    gravity_m_s2: float


@dataclass(frozen=True)
class BoundsSection:
    """``[bounds]``: the OCP's path and parameter bounds."""

    tether_length_min_m: float
    tether_length_max_m: float
    period_min_s: float
    period_max_s: float
    min_ground_clearance_m: float
    min_airspeed_m_s: float
    max_line_angle_deg: float
    surface_max_deg: float
    surface_rate_max_rad_s: float
    max_airspeed_m_s: float | None = None


@dataclass(frozen=True)
class KiteLimits:
    """The kite's own limits in force in every scenario kind (``None``: none given).

    Attributes
    ----------
    max_tether_force_n : float or None
        Largest tether tension [N].
    min_airspeed_m_s, max_airspeed_m_s : float, float or None
        Airspeed range [m/s].
    sources : dict
        Where each came from (key of the system file).
    """

    max_tether_force_n: float | None
    min_airspeed_m_s: float
    max_airspeed_m_s: float | None
    sources: dict

    def describe(self) -> str:
        """One line: the kite limits in force and where they came from."""
        force = (f"tether force <= {self.max_tether_force_n:g} N "
                 f"({self.sources['max_tether_force_n']})" if self.max_tether_force_n
                 else "no tether-force limit (the system file gives none)")
        top = (f"{self.max_airspeed_m_s:g} m/s" if self.max_airspeed_m_s is not None
               else "no upper limit (the system file gives none)")
        return (f"kite limits (all scenario kinds): {force}, airspeed from "
                f"{self.min_airspeed_m_s:g} m/s to {top}")


@dataclass(frozen=True)
class System:
    """A whole system file, validated.

    Attributes
    ----------
    name, description : str
    kite, aero, tether, winch, drive, wind, bounds
        The sections.
    path : str
        Where it was read from.
    text : str
        The file's content as read (recorded in every output).
    sha256 : str
        Hash of the parsed content (canonical JSON): the system's identity.
    paper_system : bool
        Whether this is the system of the paper the product implements
        (``[system] paper_system``): only then is a sweep compared with the paper.
    """

    name: str
    description: str
    kite: KiteSection
    aero: AeroSection
    tether: TetherSection
    winch: WinchSection
    drive: DriveSection
    wind: WindSection
    bounds: BoundsSection
    path: str
    text: str
    sha256: str
    paper_system: bool = False

    # -------------------------------------------------------------- model parameters
    def kite_params(self) -> KiteParams:
        """The kite DAE's :class:`KiteParams`."""
        k, w = self.kite, self.wind
        return KiteParams(
            mass_kg=k.mass_kg, sref_m2=k.reference_area_m2, bref_m=k.span_m, cref_m=k.chord_m,
            zt_m=k.bridle_offset_m, g_m_s2=w.gravity_m_s2, rho_kg_m3=w.air_density_kg_m3,
            j1_kg_m2=k.inertia_xx_kg_m2, j2_kg_m2=k.inertia_yy_kg_m2,
            j3_kg_m2=k.inertia_zz_kg_m2, j31_kg_m2=k.inertia_xz_kg_m2,
            tether_cd_per_m=0.25 * self.tether.drag_coefficient * self.tether.diameter_m,
            r_winch_m=self.winch.drum_radius_m, gear_ratio=self.winch.gear_ratio,
            drum_inertia_kg_m2=self.winch.drum_inertia_kg_m2 or 0.0,
            rotor_inertia_kg_m2=self.drive.rotor_inertia_kg_m2 or 0.0,
        )

    def aero_coefficients(self) -> AeroCoefficients:
        """The aerodynamic coefficients."""
        return self.aero.coefficients

    def wind_model(self) -> WindModel:
        """The wind profile."""
        w = self.wind
        return WindModel(
            reference_altitude_m=w.reference_height_m,
            roughness_length_m=w.roughness_length_m if w.profile == "log" else 0.0,
            origin_altitude_m=w.winch_height_m,
            power_law_exponent=w.exponent if w.profile == "power" else 0.0,
        )

    def ground_clearance_m(self) -> float:
        """Lowest allowed CG altitude above ground [m]: the file's value, at least half the span."""
        return max(self.bounds.min_ground_clearance_m, 0.5 * self.kite.span_m)

    def kite_limits(self) -> KiteLimits:
        """The tether-force and airspeed limits of every scenario kind."""
        t = self.tether
        candidates = [(t.max_force_n, "[tether] max_force_n"),
                      (t.working_load_n(), f"[tether] tensile_strength_pa "
                       f"{t.tensile_strength_pa or 0:g} Pa on diameter_m {t.diameter_m:g} m "
                       f"/ safety_factor {t.safety_factor or 0:g}")]
        given = [(v, src) for v, src in candidates if v is not None]
        force, source = min(given) if given else (None, "none")
        return KiteLimits(force, self.bounds.min_airspeed_m_s, self.bounds.max_airspeed_m_s,
                          {"max_tether_force_n": source,
                           "min_airspeed_m_s": "[bounds] min_airspeed_m_s",
                           "max_airspeed_m_s": "[bounds] max_airspeed_m_s"
                           if self.bounds.max_airspeed_m_s is not None else "none"})

    def ocp_options(self, options: Any, rating: Any) -> Any:
        """``options`` (an ``OcpOptions``) with this system's bounds and a drive's limits.

        Parameters
        ----------
        options : optimize.problem.options.OcpOptions
        rating : kernel.drive_rating.DriveRating
            The drive in force (:func:`optimize.system.drive_in_force.drive_in_force`): speed and
            torque limits, nominal power, the RMS torque bound of its continuous
            rating (when below the torque limit) and the grid power limit.
        """
        b, a = self.bounds, self.aero
        return options.replace(limits=dict(
            period_bounds_s=(b.period_min_s, b.period_max_s),
            tether_length_bounds_m=(b.tether_length_min_m, b.tether_length_max_m),
            min_altitude_m=self.ground_clearance_m(),
            max_speed_rpm=rating.max_speed_rpm,
            max_torque_nm=rating.max_torque_nm,
            max_p_elec_w=rating.max_p_elec_w,
            nominal_power_w=rating.nominal_power_w,
            max_rms_torque_nm=rating.rms_torque_limit_nm,
            min_airspeed_m_s=b.min_airspeed_m_s,
            max_airspeed_m_s=b.max_airspeed_m_s,
            max_tether_force_n=self.kite_limits().max_tether_force_n,
            alpha_bounds_deg=(a.alpha_min_deg, a.alpha_max_deg),
            beta_bounds_deg=(a.beta_min_deg, a.beta_max_deg),
            max_line_angle_deg=b.max_line_angle_deg,
            surface_bound_deg=b.surface_max_deg,
            surface_rate_bound_rad_s=b.surface_rate_max_rad_s,
            max_reel_acceleration_m_s2=self.winch.max_reel_acceleration_m_s2,
            base_speed_rpm=self.drive.base_speed_rpm,
            envelope_speed_rpm=self.drive.envelope_speed_rpm,
            envelope_torque_nm=self.drive.envelope_torque_nm,
        ))

    def model_params(self) -> tuple[KiteParams, AeroCoefficients, WindModel]:
        """Arguments of ``optimize.model.kite_model.kite_dae``."""
        return self.kite_params(), self.aero_coefficients(), self.wind_model()

    def drivetrain_line(self) -> str:
        """One line: the drivetrain's inertia, reel-acceleration limit and torque-speed
        envelope in force, and which are not stated."""
        w, d = self.winch, self.drive
        drum, rotor = w.drum_inertia_kg_m2, d.rotor_inertia_kg_m2
        total = (rotor or 0.0) + (drum or 0.0) / w.gear_ratio**2
        inertia = (f"inertia {total:.4g} kg m^2 at the motor (drum {drum or 0:g}, rotor "
                   f"{rotor or 0:g} kg m^2)" if drum is not None or rotor is not None
                   else "no inertia stated: a massless drum and rotor")
        accel = (f"reel acceleration <= {w.max_reel_acceleration_m_s2:g} m/s^2 (all kinds)"
                 if w.max_reel_acceleration_m_s2 is not None
                 else "no reel-acceleration limit stated")
        if d.base_speed_rpm is not None:
            envelope = f"constant power above {d.base_speed_rpm:g} rpm"
        elif d.envelope_speed_rpm is not None:
            envelope = f"torque-speed table of {len(d.envelope_speed_rpm)} points"
        else:
            envelope = "no torque-speed envelope stated (the torque limit at every speed)"
        return f"drivetrain: {inertia}; {accel}; {envelope}"

    def dae_spec(self) -> DaeSpec:
        """How a worker builds this system's model (:func:`optimize.model.kite_model.kite_dae`
        with :meth:`model_params`)."""
        return DaeSpec(kite_dae, self.model_params())

    def record(self) -> dict:
        """What every output records about the system: name, path, hash and content."""
        return {"name": self.name, "path": self.path, "sha256": self.sha256, "text": self.text}


# ------------------------------------------------------------------ parsing
_SECTIONS = ("system", "kite", "aero", "tether", "winch", "drive", "wind", "bounds")
_OPTIONAL = {
    "drive": {"max_speed_rpm", "max_torque_nm", "nominal_power_w", "max_p_elec_w",
              "continuous_torque_nm", "overload", "losses", "scaling", "source"},
    "wind": {"roughness_length_m", "exponent"},
    "tether": {"max_force_n", "tensile_strength_pa", "safety_factor"},
    "bounds": {"max_airspeed_m_s"},
    "system": {"description", "paper_system"},
}


class _Reader:
    """Pops keys from one section, checking types; raises InputError naming file and key."""

    def __init__(self, path: str, section: str, data: Any):
        if not isinstance(data, dict):
            raise InputError(path, f"[{section}]: not a table", expected=f"a [{section}] table")
        self.path, self.section, self.data = path, section, dict(data)

    def error(self, key: str, problem: str, expected: str) -> InputError:
        return InputError(self.path, f"[{self.section}] {key}: {problem}", expected=expected)

    def number(self, key: str, lo: float | None = None, strict: bool = True,
               optional: bool = False) -> float | None:
        if key not in self.data:
            if optional:
                return None
            raise self.error(key, "missing", "a number")
        value = self.data.pop(key)
        if not _number(value):
            raise self.error(key, f"{value!r} is not a finite number", "a number")
        if lo is not None and (value <= lo if strict else value < lo):
            raise self.error(key, f"{value!r} is not physical",
                             f"a number {'>' if strict else '>='} {lo:g}")
        return float(value)

    def numbers(self, key: str, optional: bool = False) -> tuple[float, ...] | None:
        """A list of at least two finite numbers."""
        if key not in self.data:
            if optional:
                return None
            raise self.error(key, "missing", "a list of numbers")
        value = self.data.pop(key)
        if not isinstance(value, list) or len(value) < 2 or not all(map(_number, value)):
            raise self.error(key, f"{value!r} is not a list of numbers",
                             "a list of at least two finite numbers")
        return tuple(float(v) for v in value)

    def text(self, key: str, choices: tuple[str, ...] | None = None,
             optional: bool = False) -> str | None:
        if key not in self.data:
            if optional:
                return None
            raise self.error(key, "missing", "a string")
        value = self.data.pop(key)
        if not isinstance(value, str):
            raise self.error(key, f"{value!r} is not a string", "a string")
        if choices is not None and value not in choices:
            raise self.error(key, f"{value!r} is not allowed", "one of " + ", ".join(choices))
        return value

    def done(self) -> None:
        if self.data:
            key = sorted(self.data)[0]
            raise self.error(key, "unknown key", "only the keys of docs/system_file.md")


def _aero(r: _Reader) -> AeroSection:
    names = [f.name for f in dataclasses.fields(AeroCoefficients)]
    coeffs = AeroCoefficients(**{n: r.number(n) for n in names})
    a_lo, a_hi = r.number("alpha_min_deg"), r.number("alpha_max_deg")
    b_lo, b_hi = r.number("beta_min_deg"), r.number("beta_max_deg")
    if not -90 < a_lo < a_hi < 90:
        raise r.error("alpha_max_deg", f"range [{a_lo:g}, {a_hi:g}]", "-90 < alpha_min < "
                      "alpha_max < 90 deg")
    if not -90 < b_lo < b_hi < 90:
        raise r.error("beta_max_deg", f"range [{b_lo:g}, {b_hi:g}]", "-90 < beta_min < "
                      "beta_max < 90 deg")
    if coeffs.cl_alpha <= 0:
        raise r.error("cl_alpha", f"{coeffs.cl_alpha!r} is not physical", "a lift slope > 0")
    r.done()
    return AeroSection(coeffs, a_lo, a_hi, b_lo, b_hi)


def _drive(r: _Reader) -> DriveSection:
    from optimize.system.drive_in_force import SCALING_CHOICES

    numbers = {k: r.number(k, 0, optional=True) for k in
               ("max_speed_rpm", "max_torque_nm", "nominal_power_w", "max_p_elec_w",
                "continuous_torque_nm", "overload")}
    if numbers["overload"] is not None and numbers["overload"] < 1:
        raise r.error("overload", f"{numbers['overload']!r}", "a factor >= 1 (peak torque over "
                      "continuous torque)")
    drive = DriveSection(**numbers, losses=r.text("losses", optional=True),
                         scaling=r.text("scaling", SCALING_CHOICES, optional=True),
                         source=r.text("source", optional=True),
                         rotor_inertia_kg_m2=r.number("rotor_inertia_kg_m2", 0, strict=False,
                                                      optional=True),
                         **_envelope(r))
    r.done()
    return drive


def _envelope(r: _Reader) -> dict:
    """``[drive]``'s torque-speed envelope: a base speed (constant power above it) or a
    datasheet table (speeds rising from 0, largest torques falling, both at the motor
    shaft), not both."""
    base = r.number("base_speed_rpm", 0, optional=True)
    speeds = r.numbers("envelope_speed_rpm", optional=True)
    torques = r.numbers("envelope_torque_nm", optional=speeds is None)
    if speeds is None and torques is not None:
        raise r.error("envelope_speed_rpm", "missing", "envelope_speed_rpm with "
                      "envelope_torque_nm (a table of speed and largest torque)")
    if speeds is not None:
        if base is not None:
            raise r.error("base_speed_rpm", "given with an envelope table",
                          "either base_speed_rpm or envelope_speed_rpm/envelope_torque_nm")
        if len(speeds) != len(torques):
            raise r.error("envelope_torque_nm", f"{len(torques)} torques for {len(speeds)} "
                          "speeds", "one torque per speed")
        if speeds[0] != 0 or any(b <= a for a, b in zip(speeds, speeds[1:], strict=False)):
            raise r.error("envelope_speed_rpm", f"{list(speeds)} is not monotone from 0",
                          "speeds rising strictly from 0 rpm")
        if min(torques) <= 0 or any(b > a for a, b in zip(torques, torques[1:], strict=False)):
            raise r.error("envelope_torque_nm", f"{list(torques)} is not monotone",
                          "positive torques that do not rise with speed")
    return {"base_speed_rpm": base, "envelope_speed_rpm": speeds,
            "envelope_torque_nm": torques}


def _check_sections(data: Any, path: str) -> None:
    if not isinstance(data, dict):
        raise InputError(path, "not a table of sections", expected="a TOML file")
    unknown = sorted(set(data) - set(_SECTIONS))
    if unknown:
        raise InputError(path, f"[{unknown[0]}]: unknown section",
                         expected="sections " + ", ".join(_SECTIONS))
    for s in _SECTIONS:
        if s not in data:
            raise InputError(path, f"[{s}]: missing section",
                             expected="sections " + ", ".join(_SECTIONS))


def _header(r: _Reader) -> tuple[str, str, bool]:
    """``[system]``: name, description and whether it is the paper's system."""
    name, description = r.text("name"), r.text("description", optional=True) or ""
    paper_system = r.data.pop("paper_system", False)
    if not isinstance(paper_system, bool):
        raise r.error("paper_system", f"{paper_system!r} is not a boolean", "true or false")
    r.done()
    return name, description, paper_system


def _kite(r: _Reader) -> KiteSection:
    kite = KiteSection(
        r.number("mass_kg", 0), r.number("reference_area_m2", 0), r.number("span_m", 0),
        r.number("chord_m", 0), r.number("bridle_offset_m", 0, strict=False),
        r.number("inertia_xx_kg_m2", 0), r.number("inertia_yy_kg_m2", 0),
        r.number("inertia_zz_kg_m2", 0), r.number("inertia_xz_kg_m2"),
    )
    r.done()
    inertia = np.array([[kite.inertia_xx_kg_m2, 0, kite.inertia_xz_kg_m2],
                        [0, kite.inertia_yy_kg_m2, 0],
                        [kite.inertia_xz_kg_m2, 0, kite.inertia_zz_kg_m2]])
    if np.min(np.linalg.eigvalsh(inertia)) <= 0:
        raise InputError(r.path, "[kite] inertia_xz_kg_m2: the inertia matrix is not positive "
                         "definite", expected="inertia_xz_kg_m2^2 < inertia_xx_kg_m2 * "
                         "inertia_zz_kg_m2")
    return kite


def _tether(r: _Reader) -> TetherSection:
    tether = TetherSection(r.number("diameter_m", 0), r.number("drag_coefficient", 0, False),
                           r.number("max_force_n", 0, optional=True),
                           r.number("tensile_strength_pa", 0, optional=True),
                           r.number("safety_factor", 0, optional=True))
    if (tether.tensile_strength_pa is None) != (tether.safety_factor is None):
        missing = "safety_factor" if tether.safety_factor is None else "tensile_strength_pa"
        raise r.error(missing, "missing", "tensile_strength_pa and safety_factor together "
                      "(the working load is strength * pi d^2 / 4 / safety factor)")
    if tether.safety_factor is not None and tether.safety_factor < 1:
        raise r.error("safety_factor", f"{tether.safety_factor:g} is below 1", "a number >= 1")
    r.done()
    return tether


def _winch(r: _Reader) -> WinchSection:
    winch = WinchSection(r.number("drum_radius_m", 0), r.number("gear_ratio", 0),
                         r.number("drum_inertia_kg_m2", 0, strict=False, optional=True),
                         r.number("max_reel_acceleration_m_s2", 0, optional=True))
    r.done()
    return winch


def _wind(r: _Reader) -> WindSection:
    profile = r.text("profile", ("log", "power"))
    ref = r.number("reference_height_m", 0)
    rough = r.number("roughness_length_m", 0, optional=profile != "log")
    exponent = r.number("exponent", 0, optional=profile != "power")
    if profile == "log" and exponent is not None:
        raise r.error("exponent", "given with profile = \"log\"", "roughness_length_m only")
    if profile == "power" and rough is not None:
        raise r.error("roughness_length_m", "given with profile = \"power\"", "exponent only")
    wind = WindSection(profile, ref, rough, exponent, r.number("winch_height_m", 0, False),
                       r.number("air_density_kg_m3", 0), r.number("gravity_m_s2", 0))
    r.done()
    return wind


def _bounds(r: _Reader) -> BoundsSection:
    bounds = BoundsSection(
        r.number("tether_length_min_m", 0), r.number("tether_length_max_m", 0),
        r.number("period_min_s", 0), r.number("period_max_s", 0),
        r.number("min_ground_clearance_m", 0, False), r.number("min_airspeed_m_s", 0, False),
        r.number("max_line_angle_deg", 0), r.number("surface_max_deg", 0),
        r.number("surface_rate_max_rad_s", 0), r.number("max_airspeed_m_s", 0, optional=True),
    )
    if bounds.max_airspeed_m_s is not None and bounds.max_airspeed_m_s <= bounds.min_airspeed_m_s:
        raise r.error("max_airspeed_m_s", "not above min_airspeed_m_s",
                      "min_airspeed_m_s < max_airspeed_m_s")
    if bounds.tether_length_max_m <= bounds.tether_length_min_m:
        raise r.error("tether_length_max_m", "not above tether_length_min_m",
                      "tether_length_min_m < tether_length_max_m")
    if bounds.period_max_s <= bounds.period_min_s:
        raise r.error("period_max_s", "not above period_min_s", "period_min_s < period_max_s")
    if bounds.max_line_angle_deg >= 90:
        raise r.error("max_line_angle_deg", f"{bounds.max_line_angle_deg:g}", "an angle < 90 deg")
    r.done()
    return bounds


def system_from_dict(data: dict, path: str = "<system>", text: str = "") -> System:
    """Validate a parsed system file (see :func:`load_system`): each section by its reader,
    then the whole system's plausibility."""
    _check_sections(data, path)
    name, description, paper_system = _header(_Reader(path, "system", data["system"]))
    kite = _kite(_Reader(path, "kite", data["kite"]))
    aero = _aero(_Reader(path, "aero", data["aero"]))
    tether = _tether(_Reader(path, "tether", data["tether"]))
    winch = _winch(_Reader(path, "winch", data["winch"]))
    drive = _drive(_Reader(path, "drive", data["drive"]))
    wind = _wind(_Reader(path, "wind", data["wind"]))
    bounds = _bounds(_Reader(path, "bounds", data["bounds"]))
    canonical = json.dumps(data, sort_keys=True, separators=(",", ":"))
    system = System(name, description, kite, aero, tether, winch, drive, wind, bounds, path,
                    text, hashlib.sha256(canonical.encode("utf-8")).hexdigest(), paper_system)
    check_system(system)  # well-formed is not enough: refuse what cannot fly, before any solve
    return system


def load_system(path: str | Path | None = None) -> System:
    """Read and validate a system file (default: the shipped ``highwind.toml``).

    Raises
    ------
    InputError
        File missing, not UTF-8 or not TOML, or any key wrong (named with the file).
    """
    path = Path(path) if path is not None else shipped_system_path()
    text = read_text(path, what="system file")
    return system_from_dict(parse_toml(text, path, what="system file"), str(path), text)
