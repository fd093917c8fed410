"""The system file of ``bench optimize --system FILE``: kite, aero, tether, winch, drive,
wind and bounds (TOML; docs/system_file.md describes every key).

:func:`optimize.system.system_file.load_system` reads and validates a file into a
frozen :class:`System` (its sections here). The shipped systems live in
``optimize/data/systems/`` (:func:`shipped_system_path`); ``highwind.toml`` is the
paper's kite and the default.

Its sections, each key declared once with its unit, range and meaning, are
:mod:`optimize.system.sections`. A :class:`System` turns into the model's parameter sets
(:meth:`System.kite_params`, :meth:`System.aero_coefficients`,
:meth:`System.wind_model`). The OCP's parts read their bounds from its sections; the
drive they fly is :meth:`System.in_force`'s ``[drive]``, the file's with the rating in
force. It is hashed on its parsed content (:attr:`System.sha256`, comments and key order
do not count), which is part of the NLP cache key and of the stored-guess acceptance.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from kernel.drive import DRIVE_KEYS, OPTIONAL_DRIVE_KEYS, Drive
from kernel.sections import bound_keys, bound_values
from optimize.model.atmosphere import ISA_LAPSE_K_M
from optimize.model.dae import DaeSpec
from optimize.model.kite_model import kite_dae
from optimize.model.params import AeroCoefficients, KiteParams, TetherModel, WindModel
from optimize.system.sections import (
    AeroSection,
    BoundsSection,
    KiteSection,
    TetherSection,
    WinchSection,
    WindSection,
)

#: folder of the shipped system files (package data)
SYSTEMS_DIR = Path(__file__).resolve().parent.parent / "data" / "systems"
DEFAULT_SYSTEM = "highwind"


def shipped_system_path(name: str = DEFAULT_SYSTEM) -> Path:
    """Path of a shipped system file by name (``"highwind"``, ``"ap2"``, ``"megawes"``)."""
    return SYSTEMS_DIR / f"{name}.toml"


@dataclass(frozen=True)
class KiteLimits:
    """The kite's tether-force and airspeed limits in force in every scenario kind
    (``None``: none given).

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


#: the ``[bounds]`` limits of every kind said after the tether force (the first) and after
#: the airspeed (the second), with how each is said
_KITE_LINE_BOUNDS = (("tension_min", ", tension >= {:g} N"),
                     ("body_rate_limit", ", body rates within {:g} deg/s"))


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
    part_inputs : tuple
        The file's sections of further parts (:data:`optimize.problem.part_sections.PART_SECTIONS`),
        in that table's order: each makes the part it is the inputs of.
    """

    name: str
    description: str
    kite: KiteSection
    aero: AeroSection
    tether: TetherSection
    winch: WinchSection
    drive: Drive
    wind: WindSection
    bounds: BoundsSection
    path: str
    text: str
    sha256: str
    paper_system: bool = False
    part_inputs: tuple[Any, ...] = ()

    def in_force(self, drive: Any, envelope_torque_nm: tuple[float, ...] | None = None
                 ) -> System:
        """This system with a drive in force: its ``[drive]`` with the rating keys of
        ``drive`` (a :class:`kernel.drive.Drive`: the drive in force,
        :func:`optimize.system.drive_in_force.drive_in_force`, or a sizing candidate's
        rating; a continuous rating or grid limit it states none of is none) and, for a
        scaled drive, its envelope table's torques; every other key (and ``source``) the
        file's. The same file (hash): the drive in force follows from it and the power
        model, both in every cache key."""
        given = {k: getattr(drive, k) for k in (*DRIVE_KEYS, *OPTIONAL_DRIVE_KEYS)}
        if envelope_torque_nm is not None:
            given["envelope_torque_nm"] = tuple(envelope_torque_nm)
        return dataclasses.replace(self, drive=dataclasses.replace(self.drive, **given))

    def drive_key(self) -> str:
        """The drive in force as canonical JSON: beside :attr:`sha256` (the file's), what a
        cache key of a problem of this system holds, since :meth:`in_force` changes the
        drive and not the file's hash."""
        return json.dumps(self.drive.keys(), sort_keys=True, default=str)

    def sections_record(self) -> dict[str, dict]:
        """Every section as flown (the drive in force), by section name, each key by its
        name in the file: what a sweep's manifest records (``sections``)."""
        return {name: (self.drive.keys() if name == "drive"
                       else dataclasses.asdict(getattr(self, name)))
                for name in ("kite", "aero", "tether", "winch", "drive", "wind", "bounds")}

    def bound_values(self) -> dict[str, Any]:
        """The value of each bound of the OCP by the name the summary's ``active_bounds``
        reports it by (docs/schemas.md §5), as flown: the sections' bound keys
        (:func:`kernel.sections.bound_values`), the ground clearance in force, the
        tether-force limit and the surfaces' deflection bounds; ``None``: not stated."""
        out = {name: value for section in (self.aero, self.bounds, self.winch, self.drive)
               for name, value in bound_values(section).items()}
        return {**out, "ground_clearance": self.ground_clearance_m(),
                "tether_force_limit": self.kite_limits().max_tether_force_n,
                "surface_limit": list(self.bounds.surface_bounds_deg())}

    # -------------------------------------------------------------- model parameters
    def kite_params(self) -> KiteParams:
        """The kite DAE's :class:`KiteParams`."""
        k, w = self.kite, self.wind
        return KiteParams(
            mass_kg=k.mass_kg, sref_m2=k.reference_area_m2, bref_m=k.span_m, cref_m=k.chord_m,
            zt_m=k.bridle_offset_m, g_m_s2=w.gravity_m_s2, rho_kg_m3=w.air_density_kg_m3,
            j1_kg_m2=k.inertia_xx_kg_m2, j2_kg_m2=k.inertia_yy_kg_m2,
            j3_kg_m2=k.inertia_zz_kg_m2, j31_kg_m2=k.inertia_xz_kg_m2,
            tether_cd_per_m=(0.25 * self.tether.drag_coefficient * self.tether.diameter_m
                             if self.tether.drag_elements is None else 0.0),
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
            temperature_lapse_k_m=ISA_LAPSE_K_M if w.atmosphere == "isa" else 0.0,
        )

    def tether_model(self) -> TetherModel:
        """The tether's mass and drag model (massless and lumped unless the file says)."""
        t = self.tether
        if t.line_mass_kg_m() is None and t.drag_elements is None:
            return TetherModel()
        return TetherModel(mass_kg_m=t.line_mass_kg_m() or 0.0, diameter_m=t.diameter_m,
                           drag_coefficient=t.drag_coefficient,
                           drag_elements=t.drag_elements or 0)

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

    def kite_limits_line(self) -> str:
        """One line: the kite limits in force in every kind and where they came from."""
        k = self.kite_limits()
        values, keys = bound_values(self.bounds), bound_keys(self.bounds)
        said = [f"{how.format(values[b])} ([bounds] {keys[b]})" if values[b] is not None
                else "" for b, how in _KITE_LINE_BOUNDS]
        force = (f"tether force <= {k.max_tether_force_n:g} N "
                 f"({k.sources['max_tether_force_n']})" if k.max_tether_force_n
                 else "no tether-force limit (the system file gives none)")
        top = (f"{k.max_airspeed_m_s:g} m/s" if k.max_airspeed_m_s is not None
               else "no upper limit (the system file gives none)")
        return (f"kite limits (all scenario kinds): {force}{said[0]}, airspeed from "
                f"{k.min_airspeed_m_s:g} m/s to {top}{said[1]}")

    def model_params(self) -> tuple[KiteParams, AeroCoefficients, WindModel, TetherModel]:
        """Arguments of ``optimize.model.kite_model.kite_dae``."""
        return self.kite_params(), self.aero_coefficients(), self.wind_model(), \
            self.tether_model()

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
        if w.max_reel_jerk_m_s3 is not None:
            accel += f", reel jerk <= {w.max_reel_jerk_m_s3:g} m/s^3 (all kinds)"
        for word, value in (("out", w.max_reel_out_speed_m_s), ("in", w.max_reel_in_speed_m_s)):
            if value is not None:
                accel += f", reel-{word} speed <= {value:g} m/s (all kinds)"
        if d.base_speed_rpm is not None:
            envelope = f"constant power above {d.base_speed_rpm:g} rpm"
        elif d.envelope_speed_rpm is not None:
            envelope = f"torque-speed table of {len(d.envelope_speed_rpm)} points"
        else:
            envelope = "no torque-speed envelope stated (the torque limit at every speed)"
        return f"drivetrain: {inertia}; {accel}; {envelope}"

    def tether_air_line(self) -> str:
        """One line: the tether's mass and drag model and the atmosphere in force."""
        t, w = self.tether_model(), self.wind
        mass = (f"{t.mass_kg_m:.4g} kg/m (a rod with its weight and mass flow)"
                if t.mass_kg_m > 0 else "massless")
        drag = (f"drag over {t.drag_elements} elements with their own apparent wind"
                if t.drag_elements else "drag lumped at the kite (a quarter of the line's)")
        air = (f"ISA from {w.air_density_kg_m3:g} kg/m^3 at the ground" if w.atmosphere == "isa"
               else f"constant density {w.air_density_kg_m3:g} kg/m^3")
        return f"tether: {mass}, {drag}; air: {air}"

    def dae_spec(self) -> DaeSpec:
        """How a worker builds this system's model (:func:`optimize.model.kite_model.kite_dae`
        with :meth:`model_params`)."""
        return DaeSpec(kite_dae, self.model_params())

    def record(self) -> dict:
        """What every output records about the system: name, path, hash and content."""
        return {"name": self.name, "path": self.path, "sha256": self.sha256, "text": self.text}
