"""Plausibility of a system file: stop the obviously impossible before any solve.

A system file can be well-formed (every key present, every number positive) and
still describe nothing that flies: a drag polar that is zero or negative, a
1e6 m span, a 1000 t wing of 0.7 m^2, a line that cannot carry the kite's
weight. The OCP would then spend minutes in IPOPT before failing, or "converge"
to a cycle of a kite that cannot exist. :func:`check_system` runs when the file
is read (:func:`optimize.system.system_file.system_from_dict`) and
:func:`check_drive_holds_kite` once the drive limits in force are known; each
raises :class:`~kernel.errors.InputError` naming the file, the ``[section] key``
to look at, the value found and the range expected.

The ranges are those of things that fly, not of the shipped files: they admit
everything from a 1 kg model wing to the largest aircraft ever built, so the
7.5 kg HIGHWIND wing, the 36.8 kg AP2 and the 6.9 t MegAWES wing are well inside.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from kernel.errors import InputError
from kernel.sections import bound_keys
from optimize.model.aero import force_coefficients

#: largest mass [kg]: the An-225's 640 t maximum take-off mass, the heaviest aircraft flown
MAX_MASS_KG = 640e3
#: largest span [m]: 117 m of the Stratolaunch carrier, the largest span flown, with margin
MAX_SPAN_M = 150.0
#: wing loading m/S [kg/m^2]: soft kites from about 0.3, airliners up to about 750
WING_LOADING_KG_M2 = (0.05, 1000.0)
#: aspect ratio b^2/S [-]: delta and soft kites from about 2, sailplanes up to about 50
ASPECT_RATIO = (1.0, 60.0)
#: chord times span over area [-]: 1 for a rectangular wing with c = S/b
CHORD_SPAN_OVER_AREA = (0.2, 5.0)
#: radius of gyration sqrt(J/m) over the span [-]: all mass on the wing tips gives 0.5
#: about roll; 0.01 would put a 40 m wing's mass within 0.4 m of its centre
GYRATION_OVER_SPAN = (0.01, 1.0)
#: principal moments of inertia of a rigid body satisfy J_i <= J_j + J_k (equality for a
#: flat plate); relative tolerance for rounded published values
INERTIA_TRIANGLE_RTOL = 0.02
#: most lift-to-drag of the wing polar [-]: the best sailplanes reach about 60
MAX_LIFT_TO_DRAG = 100.0
#: most lift coefficient of the polar [-]: high-lift flapped wings reach about 3.5
MAX_LIFT_COEFFICIENT = 4.0
#: highest speed [m/s] at which a kite may first carry its weight when the file gives no
#: upper airspeed limit (the OCP bounds each velocity component at 200 m/s)
MAX_CARRY_SPEED_M_S = 150.0
#: gravity [m/s^2] on Earth where kites fly: 9.780 at the equator to 9.832 at the poles
#: at sea level (GRS80 normal gravity, H. Moritz, J. Geodesy 74, 2000), less 0.003 per km
GRAVITY_M_S2 = (9.70, 9.90)
#: air density [kg/m^3]: about 0.5 at 7 km (ISA), 1.45 in -30 degC air at sea level
AIR_DENSITY_KG_M3 = (0.5, 1.5)
#: alpha and beta samples of the polar checks
_SAMPLES = 61


def _error(path: str, section: str, key: str, problem: str, expected: str) -> InputError:
    return InputError(path, f"[{section}] {key}: {problem}", expected=expected)


def _within(path: str, section: str, key: str, what: str, value: float,
            bounds: tuple[float, float], why: str) -> None:
    lo, hi = bounds
    if not lo <= value <= hi:
        span = f"at most {hi:g}" if lo == 0 else f"from {lo:g} to {hi:g}"
        raise _error(path, section, key, f"{what} {value:.4g} is outside what flies",
                     f"{what} {span} ({why})")


def polar(system: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Lift and drag coefficients [-] of the clean wing (surfaces at 0) over the file's
    angle ranges: ``alpha_deg``, ``beta_deg`` (grids), ``cl``, ``cd`` (shape (nb, na))."""
    a = system.aero
    c = a.coefficients
    alpha_deg = np.linspace(a.alpha_min_deg, a.alpha_max_deg, _SAMPLES)
    beta_deg = np.unique(np.array([a.beta_min_deg, 0.0, a.beta_max_deg]))
    al, be = np.meshgrid(np.radians(alpha_deg), np.radians(beta_deg))
    cl, cd, _ = force_coefficients(al, be, (0.0, 0.0, 0.0), c)
    return alpha_deg, beta_deg, np.broadcast_to(cl, al.shape), cd


def _check_polar(system: Any) -> None:
    path = system.path
    alpha_deg, beta_deg, cl, cd = polar(system)
    ib, ia = np.unravel_index(np.argmin(cd), cd.shape)
    if not cd[ib, ia] > 0:
        raise _error(path, "aero", "cd0",
                     f"the drag coefficient C_D = cd0 + cd_alpha a + cd_alpha2 a^2 + cd_beta2 "
                     f"b^2 is {cd[ib, ia]:.4g} at alpha {alpha_deg[ia]:.3g} deg, beta "
                     f"{beta_deg[ib]:.3g} deg",
                     "C_D > 0 over alpha_min_deg..alpha_max_deg and beta_min_deg..beta_max_deg "
                     "(check cd0, cd_alpha, cd_alpha2, cd_beta2)")
    if not np.max(cl) > 0:
        raise _error(path, "aero", "cl0",
                     f"the lift coefficient cl0 + cl_alpha a is at most {np.max(cl):.4g} up to "
                     f"alpha_max_deg {alpha_deg[-1]:g}", "a wing that lifts: C_L > 0 somewhere "
                     "in the alpha range")
    _within(path, "aero", "cl_alpha", "the largest lift coefficient", float(np.max(cl)),
            (0.0, MAX_LIFT_COEFFICIENT), "flapped high-lift wings reach about 3.5")
    ratio = float(np.max(cl / cd))
    _within(path, "aero", "cd0", "the best lift-to-drag ratio of the wing", ratio,
            (0.0, MAX_LIFT_TO_DRAG), "the best sailplanes reach about 60")


def _check_geometry(system: Any) -> None:
    path, k = system.path, system.kite
    _within(path, "kite", "mass_kg", "the mass [kg]", k.mass_kg, (0.0, MAX_MASS_KG),
            "640 t is the heaviest aircraft ever flown")
    _within(path, "kite", "span_m", "the span [m]", k.span_m, (0.0, MAX_SPAN_M),
            "117 m is the largest span ever flown")
    _within(path, "kite", "span_m", "the aspect ratio span^2 / reference_area",
            k.span_m**2 / k.reference_area_m2, ASPECT_RATIO,
            "delta and soft kites about 2, sailplanes up to 50")
    _within(path, "kite", "chord_m", "chord * span / reference_area",
            k.chord_m * k.span_m / k.reference_area_m2, CHORD_SPAN_OVER_AREA,
            "1 for the mean chord of a rectangular wing")
    _within(path, "kite", "mass_kg", "the wing loading mass / reference_area [kg/m^2]",
            k.mass_kg / k.reference_area_m2, WING_LOADING_KG_M2,
            "soft kites about 0.3, airliners up to about 750")
    for axis in ("xx", "yy", "zz"):
        key = f"inertia_{axis}_kg_m2"
        gyration = math.sqrt(getattr(k, key) / k.mass_kg)
        _within(path, "kite", key, f"the radius of gyration sqrt({key} / mass_kg) over span_m",
                gyration / k.span_m, GYRATION_OVER_SPAN,
                "0.5 about roll with all the mass on the wing tips")
    inertia = np.array([[k.inertia_xx_kg_m2, 0, k.inertia_xz_kg_m2],
                        [0, k.inertia_yy_kg_m2, 0],
                        [k.inertia_xz_kg_m2, 0, k.inertia_zz_kg_m2]])
    principal = np.linalg.eigvalsh(inertia)
    if principal[2] > (1 + INERTIA_TRIANGLE_RTOL) * (principal[0] + principal[1]):
        raise _error(path, "kite", "inertia_zz_kg_m2",
                     f"the largest principal inertia {principal[2]:.4g} kg m^2 exceeds the sum "
                     f"of the other two {principal[0] + principal[1]:.4g} kg m^2",
                     "inertias of a rigid body: each principal moment at most the sum of the "
                     "other two")


def _check_environment(system: Any) -> None:
    """Gravity and air density of the Earth's lower atmosphere, each against its own key."""
    w = system.wind
    _within(system.path, "wind", "gravity_m_s2", "gravity", w.gravity_m_s2, GRAVITY_M_S2,
            "the Earth's, from the equator to the poles and up to 30 km")
    _within(system.path, "wind", "air_density_kg_m3", "air density", w.air_density_kg_m3,
            AIR_DENSITY_KG_M3, "air from 7 km altitude to cold air at sea level")


def _check_weight_carried(system: Any) -> None:
    """The kite can carry its weight at some airspeed it may fly, and its line holds it."""
    path, k, w = system.path, system.kite, system.wind
    weight_n = k.mass_kg * w.gravity_m_s2
    _, _, cl, _ = polar(system)
    carry = math.sqrt(2 * weight_n / (w.air_density_kg_m3 * k.reference_area_m2 * np.max(cl)))
    top = system.bounds.max_airspeed_m_s
    key, section = ("max_airspeed_m_s", "bounds") if top is not None else ("mass_kg", "kite")
    limit = top if top is not None else MAX_CARRY_SPEED_M_S
    if carry > limit:
        raise _error(path, section, key,
                     f"the wing carries its weight only above {carry:.4g} m/s (best lift "
                     f"coefficient {np.max(cl):.3g}, {weight_n:.4g} N on "
                     f"{k.reference_area_m2:g} m^2)",
                     f"a kite that flies below {limit:g} m/s "
                     + ("(its max_airspeed_m_s)" if top is not None
                        else "(no max_airspeed_m_s given)"))
    force = system.kite_limits()
    if force.max_tether_force_n is not None and force.max_tether_force_n < weight_n:
        source = force.sources["max_tether_force_n"].split()
        raise _error(path, source[0].strip("[]"), source[1],
                     f"the tether-force limit {force.max_tether_force_n:.4g} N is below the "
                     f"kite's weight {weight_n:.4g} N", "a line that holds at least the weight")


def check_system(system: Any) -> None:
    """Refuse a system file that describes nothing that flies (see the module docstring).

    Raises
    ------
    InputError
        Naming the file and the key to look at.
    """
    _check_environment(system)
    _check_geometry(system)
    _check_polar(system)
    _check_weight_carried(system)


def check_drive_holds_kite(system: Any, drive: Any, source: str) -> None:
    """Refuse a drive whose torque limit cannot hold the kite's weight on the drum.

    Parameters
    ----------
    system : optimize.system.system.System
    drive : kernel.drive.Drive
        The drive in force (its torque limit at the motor shaft).
    source : str
        Where that limit came from (``"system file"`` or ``"power model"``).

    Raises
    ------
    InputError
        When the tension its torque limit holds on the drum
        (:meth:`kernel.drive.Drive.held_tension_n`) is below the weight.
    """
    k, w = system.kite, system.winch
    weight_n = k.mass_kg * system.wind.gravity_m_s2
    held_n = drive.held_tension_n(w.drum_radius_m, w.gear_ratio)
    if held_n < weight_n:
        key = bound_keys(drive)["torque_limit"]
        raise _error(system.path, "drive", key,
                     f"{getattr(drive, key):g} N m ({source}) on the {w.drum_radius_m:g} m drum "
                     f"with gear ratio {w.gear_ratio:g} holds {held_n:.4g} N, less than the kite's "
                     f"weight {weight_n:.4g} N",
                     f"a torque limit of at least {weight_n * w.drum_radius_m / w.gear_ratio:.4g}"
                     " N m, or a smaller drum or larger gear ratio in [winch]")
