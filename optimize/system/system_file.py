"""Reading a system file: every section's keys checked, then the whole system's plausibility.

:func:`load_system` reads and validates a file into a frozen
:class:`optimize.system.system.System`; every error (unknown or missing key, wrong
type, non-physical value such as a negative mass, an inertia that is not positive
definite or a torque-speed table that is not monotone) is an
:class:`~kernel.errors.InputError` naming the file and the key (docs/system_file.md
describes every key).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from kernel.drive_envelope import envelope_problem
from kernel.errors import InputError
from kernel.files import parse_toml, read_text
from optimize.model.aero import SURFACES, force_coefficients
from optimize.model.params import AeroCoefficients
from optimize.system.plausibility import check_system
from optimize.system.system import (
    AeroSection,
    BoundsSection,
    DriveSection,
    KiteSection,
    System,
    TetherSection,
    WinchSection,
    WindSection,
    shipped_system_path,
)


def _number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


_SECTIONS = ("system", "kite", "aero", "tether", "winch", "drive", "wind", "bounds")


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

    def coefficient(self, key: str, optional: bool = False) -> float | tuple[float, ...] | None:
        """A number, or a polynomial in alpha: a list of 1 to 8 finite numbers, ascending
        powers (returned as a tuple)."""
        if key not in self.data:
            if optional:
                return None
            raise self.error(key, "missing", "a number or a list of numbers")
        value = self.data.pop(key)
        if _number(value):
            return float(value)
        if not isinstance(value, list) or not 1 <= len(value) <= 8 or not all(map(_number,
                                                                                value)):
            raise self.error(key, f"{value!r} is neither a number nor a polynomial",
                             "a finite number, or a list of 1 to 8 finite numbers (the "
                             "coefficients of 1, alpha, alpha^2, ... with alpha in rad)")
        return tuple(float(v) for v in value)

    def integer(self, key: str, lo: int, hi: int) -> int | None:
        """An optional integer from ``lo`` to ``hi``."""
        if key not in self.data:
            return None
        value = self.data.pop(key)
        if isinstance(value, bool) or not isinstance(value, int) or not lo <= value <= hi:
            raise self.error(key, f"{value!r} is not allowed", f"an integer from {lo} to {hi}")
        return value

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


#: coefficients a system file may leave out (0: the paper's kite has none of them)
OPTIONAL_COEFFICIENTS = ("cl_q", "cd_q", "cy_p", "cy_r", "cy_ail", "cl_rud", "cn_ail")


def _aero(r: _Reader) -> AeroSection:
    names = [f.name for f in dataclasses.fields(AeroCoefficients)]
    given = {n: r.coefficient(n, optional=n in OPTIONAL_COEFFICIENTS) for n in names}
    coeffs = AeroCoefficients(**{n: v for n, v in given.items() if v is not None})
    a_lo, a_hi = r.number("alpha_min_deg"), r.number("alpha_max_deg")
    b_lo, b_hi = r.number("beta_min_deg"), r.number("beta_max_deg")
    if not -90 < a_lo < a_hi < 90:
        raise r.error("alpha_max_deg", f"range [{a_lo:g}, {a_hi:g}]", "-90 < alpha_min < "
                      "alpha_max < 90 deg")
    if not -90 < b_lo < b_hi < 90:
        raise r.error("beta_max_deg", f"range [{b_lo:g}, {b_hi:g}]", "-90 < beta_min < "
                      "beta_max < 90 deg")
    slope = _lift_slope(coeffs, a_lo, a_hi)
    if slope <= 0:
        raise r.error("cl_alpha", f"the lift slope dC_L/dalpha falls to {slope:.4g} per rad "
                      f"in [{a_lo:g}, {a_hi:g}] deg", "a lift slope > 0 over the alpha range")
    r.done()
    return AeroSection(coeffs, a_lo, a_hi, b_lo, b_hi)


def _lift_slope(coeffs: AeroCoefficients, a_lo_deg: float, a_hi_deg: float) -> float:
    """Smallest lift slope dC_L/dalpha [1/rad] of the clean wing over the alpha range
    (central differences on 51 points; ``cl_alpha`` itself for a linear lift)."""
    if not isinstance(coeffs.cl0, tuple) and not isinstance(coeffs.cl_alpha, tuple):
        return coeffs.cl_alpha
    alpha = np.radians(np.linspace(a_lo_deg, a_hi_deg, 51))
    cl = force_coefficients(alpha, 0.0, (0.0, 0.0, 0.0), coeffs)[0]
    return float(np.min(np.diff(cl) / np.diff(alpha)))


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
                         **_envelope(r), **_winding(r))
    r.done()
    return drive


def _winding(r: _Reader) -> dict:
    """``[drive]``'s thermal rating: the largest winding temperature and the ambient (or
    coolant) temperature [degC], both optional; the limit above the ambient."""
    limit = r.number("max_winding_temperature_c", -273.15, optional=True)
    ambient = r.number("ambient_temperature_c", -273.15, optional=True)
    if limit is not None and limit > 300:
        raise r.error("max_winding_temperature_c", f"{limit!r} degC is not physical",
                      "a winding limit up to 300 degC (insulation class H is 180 degC)")
    if ambient is not None and not -60 <= ambient <= 80:
        raise r.error("ambient_temperature_c", f"{ambient!r} degC is not physical",
                      "an ambient temperature from -60 to 80 degC")
    if limit is not None and ambient is not None and not limit > ambient:
        raise r.error("max_winding_temperature_c", f"{limit:g} degC, not above the ambient "
                      f"{ambient:g} degC", "a winding limit above ambient_temperature_c")
    return {"max_winding_temperature_c": limit, "ambient_temperature_c": ambient}


def _envelope(r: _Reader) -> dict:
    """``[drive]``'s torque-speed envelope: a base speed (constant power above it) or a
    datasheet table (speeds rising from 0, largest torques falling, both at the motor
    shaft), not both (:func:`kernel.drive_envelope.envelope_problem`)."""
    base = r.number("base_speed_rpm", 0, optional=True)
    speeds = r.numbers("envelope_speed_rpm", optional=True)
    torques = r.numbers("envelope_torque_nm", optional=True)
    problem = envelope_problem(base, speeds, torques)
    if problem is not None:
        raise r.error(*problem)
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
    diameter = r.number("diameter_m", 0)
    tether = TetherSection(diameter, r.number("drag_coefficient", 0, False),
                           r.number("max_force_n", 0, optional=True),
                           r.number("tensile_strength_pa", 0, optional=True),
                           r.number("safety_factor", 0, optional=True),
                           _line_mass(r, diameter), r.integer("drag_elements", 1, 100))
    if (tether.tensile_strength_pa is None) != (tether.safety_factor is None):
        missing = "safety_factor" if tether.safety_factor is None else "tensile_strength_pa"
        raise r.error(missing, "missing", "tensile_strength_pa and safety_factor together "
                      "(the working load is strength * pi d^2 / 4 / safety factor)")
    if tether.safety_factor is not None and tether.safety_factor < 1:
        raise r.error("safety_factor", f"{tether.safety_factor:g} is below 1", "a number >= 1")
    r.done()
    return tether


def _line_mass(r: _Reader, diameter_m: float) -> float | None:
    """``[tether]``'s mass per length [kg/m]: ``mass_kg_m``, or ``density_kg_m3`` times the
    cross-section ``pi d^2 / 4`` (not both; ``None``: a massless line)."""
    per_length = r.number("mass_kg_m", 0, strict=False, optional=True)
    density = r.number("density_kg_m3", 0, optional=True)
    if per_length is not None and density is not None:
        raise r.error("density_kg_m3", "given with mass_kg_m", "mass_kg_m or density_kg_m3, "
                      "not both")
    if density is not None:
        if not 100 <= density <= 20000:
            raise r.error("density_kg_m3", f"{density!r} kg/m^3 is not a line's",
                          "a density from 100 to 20000 kg/m^3 (Dyneema 970, steel 7850)")
        return density * math.pi * diameter_m**2 / 4
    return per_length


def _winch(r: _Reader) -> WinchSection:
    winch = WinchSection(r.number("drum_radius_m", 0), r.number("gear_ratio", 0),
                         r.number("drum_inertia_kg_m2", 0, strict=False, optional=True),
                         r.number("max_reel_acceleration_m_s2", 0, optional=True),
                         r.number("max_reel_jerk_m_s3", 0, optional=True),
                         r.number("max_reel_out_speed_m_s", 0, optional=True),
                         r.number("max_reel_in_speed_m_s", 0, optional=True))
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
                       r.number("air_density_kg_m3", 0), r.number("gravity_m_s2", 0),
                       r.text("atmosphere", ("constant", "isa"), optional=True) or "constant")
    r.done()
    return wind


def _bounds(r: _Reader) -> BoundsSection:
    bounds = BoundsSection(
        r.number("tether_length_min_m", 0), r.number("tether_length_max_m", 0),
        r.number("period_min_s", 0), r.number("period_max_s", 0),
        r.number("min_ground_clearance_m", 0, False), r.number("min_airspeed_m_s", 0, False),
        r.number("max_line_angle_deg", 0), r.number("surface_max_deg", 0),
        r.number("surface_rate_max_rad_s", 0), r.number("max_airspeed_m_s", 0, optional=True),
        r.number("max_body_rate_deg_s", 0, optional=True),
        r.number("min_tension_n", 0, strict=False, optional=True),
        *(r.number(f"{s}_max_deg", 0, optional=True) for s in SURFACES),
    )
    if bounds.max_airspeed_m_s is not None and bounds.max_airspeed_m_s <= bounds.min_airspeed_m_s:
        raise r.error("max_airspeed_m_s", "not above min_airspeed_m_s",
                      "min_airspeed_m_s < max_airspeed_m_s")
    if bounds.tether_length_max_m <= bounds.tether_length_min_m:
        raise r.error("tether_length_max_m", "not above tether_length_min_m",
                      "tether_length_min_m < tether_length_max_m")
    if bounds.period_max_s <= bounds.period_min_s:
        raise r.error("period_max_s", "not above period_min_s", "period_min_s < period_max_s")
    for name, value in zip(SURFACES, bounds.surface_bounds_deg(), strict=True):
        if value >= 90:
            key = f"{name}_max_deg" if getattr(bounds, f"{name}_max_deg") else "surface_max_deg"
            raise r.error(key, f"{value:g}", "an angle < 90 deg")
    if bounds.max_line_angle_deg >= 90:
        raise r.error("max_line_angle_deg", f"{bounds.max_line_angle_deg:g}", "an angle < 90 deg")
    r.done()
    return bounds


def _check_tension_range(path: str, tether: TetherSection, bounds: BoundsSection) -> None:
    """The tension floor below the tether-force limit (when both are given)."""
    top = [v for v in (tether.max_force_n, tether.working_load_n()) if v is not None]
    if bounds.min_tension_n is not None and top and bounds.min_tension_n >= min(top):
        raise InputError(path, f"[bounds] min_tension_n: {bounds.min_tension_n:g} N is not "
                         f"below the tether-force limit {min(top):g} N",
                         expected="a tension floor below [tether] max_force_n (or the "
                         "line's working load)")


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
    _check_tension_range(path, tether, bounds)
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
