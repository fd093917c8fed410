"""A drive, declared once: its rating, torque-speed envelope, where its losses come from,
its thermal rating and, in force, its losses, each quantity with one name (:class:`Drive`;
its losses' protocol, :class:`DriveModel`).

Every stage reads the drive from this type: a campaign's ``drive.toml``
(:mod:`kernel.drive_file`), a power model's ``drive`` (docs/schemas.md §3), a system
file's ``[drive]`` (docs/system_file.md: :class:`Drive` is that section), the drive in
force of a sweep and its manifest's ``sections.drive``, sizing's candidates and the
cycle export. Its dict form has one reader (:meth:`Drive.from_dict`) and one writer
(:meth:`Drive.to_dict`); the figures derived from it (the torque at a speed, the RMS
torque bound, the constant power of the envelope, a scaled drive) are its methods.

Speed and torque are those of the shaft the power model is written for (the drum, or
the motor behind a gearbox). A permanent-magnet machine gives its rated torque up to its
base speed; above it the voltage limit lets the torque fall roughly as ``P / w`` (field
weakening). A rating states that envelope one of two ways, in both quadrants::

    base_speed_rpm = 1000.0                  # constant power T_max w_base above it
    envelope_speed_rpm = [0, 1000, 1500]     # or a datasheet table: speeds rising from 0
    envelope_torque_nm = [78, 78, 52]        # and the largest torques, not rising

The OCP's smooth form of the envelope is :mod:`optimize.model.envelope`.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from kernel.errors import InputError
from kernel.sections import number, numbers, text
from kernel.thermal_model import ThermalModel
from kernel.units import RPM_PER_RAD_S, unit_of

#: The rating keys every complete rating states (drive.toml, power_model.json's ``drive``).
DRIVE_KEYS = ("nominal_power_w", "max_speed_rpm", "max_torque_nm")
#: Optional rating keys.
OPTIONAL_DRIVE_KEYS = ("continuous_torque_nm", "overload", "max_p_elec_w")
#: The envelope's keys (each optional; a base speed or a table, not both).
ENVELOPE_KEYS = ("base_speed_rpm", "envelope_speed_rpm", "envelope_torque_nm")
#: The drive's speed and torque limits: the box it may run in (:meth:`Drive.box`).
BOX_KEYS = ("max_speed_rpm", "max_torque_nm")
#: The keys of the rating's dict form (:meth:`Drive.to_dict`), ``source`` besides.
RATING_KEYS = (*DRIVE_KEYS, *OPTIONAL_DRIVE_KEYS, *ENVELOPE_KEYS)
#: ``scaling`` values: carry the losses by the similarity law (efficiency kept, or moved
#: with rating as the IE3 class moves), or use them as they are
SCALING_CHOICES = ("similarity", "similarity-ie3", "none")

_Problems = list[tuple[str, str, str]]


class DriveModel(Protocol):
    """A drive's losses (:attr:`Drive.power_model`): everything optimize uses of a power
    model (``fitting.power_model.PowerModel``), declared here so that the drive can hold
    them without the kernel importing fitting.

    Attributes
    ----------
    name : str
        What the model is (printed, recorded in the manifest).
    sha256 : str
        Its identity: part of the NLP cache key and of a stored solve's.
    nominal_power_w : float
        The drive's nominal power [W] (its rating's, where it records one), where the system
        states none.
    drive : Drive or None
        The rating its file records (docs/schemas.md §3), where the system states none.
    thermal : kernel.thermal_model.ThermalModel or None
        Its winding's thermal model (docs/schemas.md §3 ``thermal``), or None.
    copper_w_per_nm2 : float
        Its copper loss's coefficient [W/(N m)^2], the part of its losses that follows the
        winding's temperature (:class:`optimize.model.thermal.WindingThermal`).
    domain : dict or None
        ``quadrant -> polygon``: where its points were measured, or None.
    provenance : dict or None
        Where the model comes from (a carried model records it as its origin's).
    """

    name: str
    sha256: str
    nominal_power_w: float
    drive: Drive | None
    thermal: ThermalModel | None
    copper_w_per_nm2: float
    domain: dict | None
    provenance: dict | None

    def casadi_p_elec_w(self, speed_rpm: Any, torque_nm: Any) -> Any:
        """Electrical power drawn from the grid [W] (CasADi expression)."""

    def p_elec_w(self, speed_rpm: Any, torque_nm: Any) -> np.ndarray:
        """Electrical power drawn from the grid [W] (numpy)."""

    def to_dict(self) -> dict:
        """Its file's content (docs/schemas.md §3): a sweep keeps a carried model's."""

    def carried(self, speed_ratio: float, torque_ratio: float, loss_ratio: float = 1.0,
                **changes: Any) -> DriveModel:
        """The model at the corresponding points of a drive ``speed_ratio`` times its speed
        and ``torque_ratio`` times its torque, its losses ``loss_ratio`` times the similarity
        law's, with ``changes`` (:meth:`fitting.power_model.PowerModel.carried`): all that
        :func:`optimize.model.drivetrain.carry_power_model` asks of the polynomial."""


@dataclass(frozen=True, kw_only=True)
class Drive:
    """A drive: rating, envelope, losses and thermal rating (``None``: not stated).

    A system file's ``[drive]`` section is this class (its keys' docs below are the
    docs/system_file.md table); a complete rating states the three :data:`DRIVE_KEYS`
    (:meth:`rating`, :meth:`from_dict`). The drive in force
    (:func:`optimize.system.drive_in_force.drive_in_force`) and a sizing candidate carry
    their losses, :attr:`power_model`: no key of the file, of the dict form or of a record
    (:meth:`keys`), and not compared.
    """

    max_speed_rpm: float | None = number("speed limit of the constrained scenarios (`*-lim`)",
                                         lo=0, default=None, bound="speed_limit")
    max_torque_nm: float | None = number(
        "torque limit of the constrained scenarios: the drive's largest torque, short-time "
        "peak included. Every stage flies it: `bench optimize`'s constrained kinds and `bench "
        "size`'s reference drive x1 (its candidates fly it scaled). A drive allowed a "
        "short-time overload states that torque here, with `continuous_torque_nm` as its RMS "
        "rating (e.g. `max_torque_nm = 500.0`, `continuous_torque_nm = 200.0`: peaks up to "
        "500 N m, RMS at most 200 N m)", lo=0, default=None, bound="torque_limit")
    nominal_power_w: float | None = number(
        "nominal power: the capacity factor's rating (`bench aep`) and the scale of the "
        "objective", lo=0, default=None)
    max_p_elec_w: float | None = number("limit on |P_elec| (grid connection) in the "
                                        "constrained scenarios", lo=0, default=None,
                                        bound="p_elec_limit")
    continuous_torque_nm: float | None = number(
        "continuous (thermal) torque rating: the RMS torque over the cycle at most this in the "
        "constrained scenarios (applied when below `max_torque_nm`; `bench size`'s rated "
        "torque, scaled with its candidates)", lo=0, default=None)
    overload: float | None = number(
        "the datasheet's short-time torque over the continuous rating, for the record only: "
        "no stage flies it (`bench size` says so when it is above `max_torque_nm`); to fly it, "
        "state the short-time torque as `max_torque_nm`. The shipped `highwind.toml` states "
        "the paper's 5 (section II) and flies 78 N m, as the paper's optimization does",
        lo=1, lo_strict=False, default=None)
    losses: str | None = text(
        "the drive's losses: `\"paper\"` (the shipped paper Table I model, "
        "`optimize/data/paper_drive_model.json`, with its source) or a `power_model.json` of "
        "`bench fit`, the path relative to this file", default=None)
    scaling: str | None = text(
        "how the losses are carried to this rating: `\"similarity\"` (the law below, the "
        "base drive's efficiency kept), `\"similarity-ie3\"` (the same law, the losses per "
        "unit of rating moved as the IEC 60034-30-1 IE3 class's `1 - eta` moves between the "
        "two nominal powers) or `\"none\"` (used as they are)", choices=SCALING_CHOICES,
        default=None)
    source: str | None = text("where the rating comes from (printed with it)", default=None)
    rotor_inertia_kg_m2: float | None = number(
        "inertia turning at motor speed (rotor, gearbox input side); referred to the drum "
        "through `gear_ratio^2` (see `[winch]`)", lo=0, lo_strict=False, default=None)
    base_speed_rpm: float | None = number(
        "the torque-speed envelope by a base speed: above it the largest torque falls as "
        "`max_torque_nm * base_speed_rpm / |n|` (constant power, field weakening), in both "
        "quadrants, in the constrained scenarios: the smooth rows `|T w| <= max_torque_nm * "
        "w_base`; reported as `envelope_limit`", lo=0, default=None, bound="envelope_limit")
    envelope_speed_rpm: tuple[float, ...] | None = numbers(
        "instead of `base_speed_rpm`, with `envelope_torque_nm`: a datasheet's envelope, "
        "motor speeds rising strictly from 0", default=None)
    envelope_torque_nm: tuple[float, ...] | None = numbers(
        "the largest torque at each speed of `envelope_speed_rpm` (positive, not rising), "
        "linear between the points and flat beyond the last; enforced through a smooth lower "
        "bound within `w (ln 2 sum |slope changes| + max |slope|)` of the table, `w` = 0.5 % "
        "of its last speed", default=None)
    max_winding_temperature_c: float | None = number(
        "the drive's thermal rating, the largest winding temperature. With a power model that "
        "has a thermal model (`bench fit` of sessions that log the winding temperature, "
        "docs/schemas.md §3 `thermal`), the winding temperature is a state of the cycle with a "
        "periodic boundary condition (its cyclic steady state: the cycle flown for hours, IEC "
        "60034-1 duty type S6), the copper loss follows it, and this bound replaces the "
        "RMS-torque row of `continuous_torque_nm` in the constrained scenarios; reported as "
        "`winding_temperature_limit`. Without a thermal model the RMS-torque row stands and "
        "`bench optimize` says the limit is not applied", lo=-273.15, hi=300, default=None,
        bound="winding_temperature_limit",
        source="IEC 60085 thermal class H is 180 degC")
    ambient_temperature_c: float | None = number(
        "the ambient or coolant temperature of the thermal model in the cycle, below the "
        "winding limit", lo=-60, hi=80, lo_strict=False, default=None,
        absent="the one the thermal model was fitted with")

    #: the losses at this rating (a :class:`DriveModel`, with the winding's thermal model
    #: when it has one); None for a section as read or a rating alone
    power_model: DriveModel | None = dataclasses.field(default=None, compare=False,
                                                        repr=False)

    def __post_init__(self) -> None:
        for key in ENVELOPE_KEYS[1:]:
            if getattr(self, key) is not None:
                object.__setattr__(self, key, tuple(float(v) for v in getattr(self, key)))

    # ------------------------------------------------------------------ construction
    @classmethod
    def rating(cls, nominal_power_w: float, max_speed_rpm: float, max_torque_nm: float,
               **keys: Any) -> Drive:
        """A complete rating, checked (:meth:`rating_problem`).

        Raises
        ------
        ValueError
            A rating key not a finite positive number, an overload below 1, or an envelope
            that is not one (naming the key).
        """
        drive = cls(nominal_power_w=nominal_power_w, max_speed_rpm=max_speed_rpm,
                    max_torque_nm=max_torque_nm, **keys)
        problem = drive.rating_problem()
        if problem is not None:
            raise ValueError("{} = {}: {} expected".format(*problem))
        return drive.floats()

    def floats(self) -> Drive:
        """This drive with every stated number a float."""
        return dataclasses.replace(self, **{
            k: float(v) for k in (*DRIVE_KEYS, *OPTIONAL_DRIVE_KEYS, "base_speed_rpm")
            if finite_number(v := getattr(self, k))})

    @classmethod
    def from_dict(cls, data: Any, path: Path | str | None = None, where: str = "drive",
                  rating: bool = False) -> Drive:
        """The one reader of the dict form: a power model's ``drive``, a manifest's
        ``sections.drive``, a ``drive.toml``'s keys (a key ``None``: not stated).

        Parameters
        ----------
        data : dict
            The keys of :class:`Drive`.
        path : Path or str, optional
            The file named in errors.
        where : str
            Where in the file the mapping is (named in errors).
        rating : bool
            Read a complete rating (:meth:`to_dict`'s keys only, the three
            :data:`DRIVE_KEYS` required, :meth:`rating_problem`) rather than any of the
            section's keys.

        Raises
        ------
        InputError
            Not a mapping, an unknown key, or a bad value (naming file and key).
        """
        if not isinstance(data, dict):
            raise InputError(path, f"{where}: {data!r} is not an object",
                             expected="an object of drive keys")
        problem = dict_problem(data, where, rating)
        if problem is not None:
            raise InputError(path, problem, expected="docs/schemas.md's drive keys")
        return cls(**{k: v for k, v in data.items() if v is not None})

    def to_dict(self) -> dict:
        """The one writer of the rating's dict form (a power model's ``drive``, what
        :meth:`from_dict` reads back): the three :data:`DRIVE_KEYS`, the optional rating
        and envelope keys it states (lists for the table), and ``source``."""
        out = {k: getattr(self, k) for k in DRIVE_KEYS}
        out.update({k: getattr(self, k) for k in OPTIONAL_DRIVE_KEYS
                    if getattr(self, k) is not None})
        out.update(self.envelope)
        return {**out, "source": self.source or ""}

    def rating_part(self) -> Drive:
        """The rating alone: the :data:`DRIVE_KEYS`, the :data:`OPTIONAL_DRIVE_KEYS` it
        states and ``source``, no envelope or other key: the rating a power model carried to
        this drive records as its ``drive`` (and a sizing candidate scales)."""
        return Drive(**{k: getattr(self, k) for k in (*DRIVE_KEYS, *OPTIONAL_DRIVE_KEYS)},
                     source=self.source)

    def keys(self) -> dict[str, Any]:
        """Every key of the section by its name (``None``: not stated), the losses aside: what
        a sweep's manifest records (``sections.drive``) and a stored solve's key holds."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)
                if f.name != "power_model"}

    def with_losses(self, power_model: DriveModel | None) -> Drive:
        """This drive with its losses (:attr:`power_model`)."""
        return dataclasses.replace(self, power_model=power_model)

    @property
    def thermal_model(self) -> ThermalModel | None:
        """Its winding's thermal model: its losses' (None without losses or without one)."""
        return None if self.power_model is None else self.power_model.thermal

    # ------------------------------------------------------------------------ checks
    def rating_problem(self) -> tuple[str, str, str] | None:
        """What keeps this from being a complete rating, or None: ``(key, what is wrong,
        what was expected)``."""
        for key in (*DRIVE_KEYS, *OPTIONAL_DRIVE_KEYS):
            value = getattr(self, key)
            if key in OPTIONAL_DRIVE_KEYS and value is None:
                continue
            if not (finite_number(value) and value > 0):
                return key, repr(value), f"a finite positive number [{unit_of(key) or '-'}]"
        if self.overload is not None and self.overload < 1:
            return "overload", repr(self.overload), "a factor >= 1"
        if self.source is not None and not isinstance(self.source, str):
            return "source", repr(self.source), "a string"
        return self.envelope_problem()

    def envelope_problem(self) -> tuple[str, str, str] | None:
        """What is wrong with the envelope's keys, or None."""
        return envelope_problem(self.base_speed_rpm, self.envelope_speed_rpm,
                                self.envelope_torque_nm)

    def problems(self) -> _Problems:
        """The section's checks: the envelope's keys; the winding limit above the ambient."""
        problem = self.envelope_problem()
        if problem is not None:
            return [problem]
        limit, ambient = self.max_winding_temperature_c, self.ambient_temperature_c
        if limit is not None and ambient is not None and not limit > ambient:
            return [("max_winding_temperature_c", f"{limit:g} degC, not above the ambient "
                     f"{ambient:g} degC", "a winding limit above ambient_temperature_c")]
        return []

    # ---------------------------------------------------------------- derived figures
    @property
    def envelope(self) -> dict:
        """The envelope keys it states (lists for the table)."""
        return {k: (list(v) if isinstance(v, tuple) else v)
                for k in ENVELOPE_KEYS if (v := getattr(self, k)) is not None}

    def has_envelope(self) -> bool:
        """Whether it states a torque-speed envelope (a base speed or a table)."""
        return self.base_speed_rpm is not None or self.envelope_speed_rpm is not None

    @property
    def rms_torque_limit_nm(self) -> float | None:
        """The RMS torque bound the continuous rating sets [N m]: ``continuous_torque_nm``
        when below ``max_torque_nm`` (else the torque limit already implies it), else None."""
        c, top = self.continuous_torque_nm, self.max_torque_nm
        return c if c is not None and top is not None and c < top else None

    def largest_torque_nm(self, speed_rpm: Any) -> np.ndarray:
        """The largest torque [N m] at ``speed_rpm`` (either sign): the envelope (a table
        linear between its points and flat beyond the last) capped by the torque limit
        (none when not stated); the torque limit alone without an envelope
        (:func:`largest_torque_nm`)."""
        top = np.inf if self.max_torque_nm is None else self.max_torque_nm
        return largest_torque_nm(speed_rpm, top, self.base_speed_rpm,
                                 self.envelope_speed_rpm, self.envelope_torque_nm)

    def thermal_torque_nm(self) -> float | None:
        """The torque [N m] it carries continuously: the RMS bound of its continuous rating
        (:attr:`rms_torque_limit_nm`), else its torque limit."""
        return self.rms_torque_limit_nm or self.max_torque_nm

    def corner_speed_rpm(self, torque_nm: float | None = None) -> float:
        """The speed [rpm] at which a torque (default: the torque limit) gives the nominal
        power, ``P_nom / T``."""
        torque = self.max_torque_nm if torque_nm is None else torque_nm
        return self.nominal_power_w / torque * RPM_PER_RAD_S

    def constant_power_w(self, up_to_rpm: float | None = None) -> float:
        """The power [W] of the constant-power region above the base speed, ``T_max
        w_base``; with ``up_to_rpm`` the largest power up to that speed, ``T_max min(w_base,
        w)``. A base speed is required."""
        corner = self.base_speed_rpm if up_to_rpm is None else min(self.base_speed_rpm,
                                                                   up_to_rpm)
        return self.max_torque_nm * corner / RPM_PER_RAD_S

    def corner_rpm(self) -> float:
        """The corner of the constant-torque region [rpm]: the base speed when it states a
        constant-power envelope, else the speed limit."""
        base = self.base_speed_rpm
        return float(base) if base is not None else float(self.max_speed_rpm)

    def peak_power_w(self, envelope: Any = None) -> float:
        """The most shaft power [W] a cycle can draw within the rating's limits: the torque
        limit at the base speed (capped by the speed limit), the largest ``T n`` at a
        table's points up to the speed limit, else the torque limit at the speed limit.
        ``envelope``: the drive whose envelope applies (default: this one's)."""
        env = self if envelope is None else envelope
        w = math.pi / 30.0
        base = getattr(env, "base_speed_rpm", None)
        speeds = getattr(env, "envelope_speed_rpm", None)
        if base is not None:
            return self.max_torque_nm * min(base, self.max_speed_rpm) * w
        if speeds is not None:
            n = np.append(np.asarray(speeds, float), self.max_speed_rpm)
            n = n[n <= self.max_speed_rpm]
            t = np.minimum(np.interp(n, speeds, env.envelope_torque_nm), self.max_torque_nm)
            return float(np.max(n * t)) * w
        return self.max_torque_nm * self.max_speed_rpm * w

    def box(self) -> tuple[float | None, float | None]:
        """The speed [rpm] and torque [N m] limits: the box ``|n| <= max_speed_rpm``, ``0 <=
        T <= max_torque_nm`` the drive may run in (``None``: not stated)."""
        return self.max_speed_rpm, self.max_torque_nm

    def box_text(self) -> str:
        """:meth:`box` in words: ``"torque <= 78 N m and speed <= 1500 rpm"``."""
        return f"torque <= {self.max_torque_nm:g} N m and speed <= {self.max_speed_rpm:g} rpm"

    def rating_text(self, power: bool = True) -> str:
        """``"1500 rpm, 78 N m, 8200 W"``: the speed and torque limits and (``power``) the
        nominal power."""
        text = f"{self.max_speed_rpm:g} rpm, {self.max_torque_nm:g} N m"
        return text + (f", {self.nominal_power_w:g} W" if power else "")

    def held_tension_n(self, drum_radius_m: float, gear_ratio: float,
                       torque_nm: float | None = None) -> float:
        """The tether tension [N] a torque at the motor shaft holds on the drum (default: the
        torque limit): ``T i / r``."""
        torque = self.max_torque_nm if torque_nm is None else torque_nm
        return torque * gear_ratio / drum_radius_m

    def scaled(self, speed_ratio: float, torque_ratio: float, source: str,
               keep: tuple[str, ...] = ()) -> Drive:
        """This rating carried to a drive ``speed_ratio`` (``k_n``) times its speed rating
        and ``torque_ratio`` (``k_T``) times its torque rating (the similarity law,
        :func:`optimize.model.drivetrain.carry_power_model`): the speed limit times ``k_n``,
        the torque limit and the continuous torque times ``k_T``, the nominal power and the
        grid limit times ``k_n k_T``; the keys in ``keep`` and the envelope as they are."""
        k_n, k_t = float(speed_ratio), float(torque_ratio)
        factors = {"nominal_power_w": k_n * k_t, "max_speed_rpm": k_n, "max_torque_nm": k_t,
                   "continuous_torque_nm": k_t, "max_p_elec_w": k_n * k_t}
        return dataclasses.replace(self, source=source, **{
            k: f * getattr(self, k) for k, f in factors.items()
            if getattr(self, k) is not None and k not in keep})

    def line(self) -> str:
        """One line for summaries and reports."""
        extra = "".join(
            f", {label} {getattr(self, key):g} {unit}" for key, label, unit in (
                ("continuous_torque_nm", "continuous", "N m"),
                ("overload", "datasheet overload (not flown)", "x"),
                ("max_p_elec_w", "|P_elec| <=", "W"))
            if getattr(self, key) is not None)
        return (f"drive: {self.nominal_power_w:g} W nominal, |speed| <= {self.max_speed_rpm:g} "
                f"rpm, torque <= {self.max_torque_nm:g} N m{extra} ({self.source or ''})")


def finite_number(value: Any) -> bool:
    return (isinstance(value, (int, float)) and not isinstance(value, bool)
            and math.isfinite(value))


def dict_problem(data: dict, where: str = "drive", rating: bool = True) -> str | None:
    """What keeps ``data`` from being a drive's dict form, or None: an unknown key, a value
    of the wrong kind, and (``rating``) what keeps it from being a complete rating
    (:meth:`Drive.rating_problem`; only :meth:`Drive.to_dict`'s keys)."""
    known = {*RATING_KEYS, "source"} if rating else set(Drive().keys())
    unknown = sorted(set(data) - known)
    if unknown:
        return f"{where}: unknown key {unknown[0]!r}"
    for key, value in data.items():
        if value is not None and (expected := _kind_problem(key, value)) is not None:
            return f"{where}.{key}: {expected} expected, got {value!r}"
    if not rating:
        return None
    problem = Drive(**{k: v for k, v in data.items() if v is not None}).rating_problem()
    if problem is None:
        return None
    key, what, expected = problem
    return f"{where}.{key}: {expected} expected, got {what}"


def _kind_problem(key: str, value: Any) -> str | None:
    """What a dict-form value of ``key`` should have been, or None when it is of its kind."""
    if key in ("losses", "scaling", "source"):
        return None if isinstance(value, str) else "a string"
    if key in ENVELOPE_KEYS[1:]:
        ok = isinstance(value, (list, tuple)) and all(finite_number(v) for v in value)
        return None if ok else "a list of numbers"
    return None if finite_number(value) else f"a number [{unit_of(key) or '-'}]"


def envelope_problem(base_speed_rpm: float | None, speeds_rpm, torques_nm
                     ) -> tuple[str, str, str] | None:
    """What is wrong with an envelope's keys, or None.

    Returns
    -------
    tuple of str or None
        ``(key, what is wrong, what was expected)``.
    """
    if base_speed_rpm is not None and not base_speed_rpm > 0:
        return "base_speed_rpm", f"{base_speed_rpm!r}", "a base speed > 0 rpm"
    if speeds_rpm is None:
        if torques_nm is not None:
            return ("envelope_speed_rpm", "missing", "envelope_speed_rpm with "
                    "envelope_torque_nm (a table of speed and largest torque)")
        return None
    if torques_nm is None:
        return ("envelope_torque_nm", "missing", "envelope_torque_nm with "
                "envelope_speed_rpm (a table of speed and largest torque)")
    if base_speed_rpm is not None:
        return ("base_speed_rpm", "given with an envelope table",
                "either base_speed_rpm or envelope_speed_rpm/envelope_torque_nm")
    speeds, torques = list(speeds_rpm), list(torques_nm)
    if len(speeds) != len(torques):
        return ("envelope_torque_nm", f"{len(torques)} torques for {len(speeds)} speeds",
                "one torque per speed")
    if len(speeds) < 2 or speeds[0] != 0 or any(b <= a for a, b in zip(speeds, speeds[1:],
                                                                        strict=False)):
        return ("envelope_speed_rpm", f"{speeds} is not monotone from 0",
                "speeds rising strictly from 0 rpm (at least two)")
    if min(torques) <= 0 or any(b > a for a, b in zip(torques, torques[1:], strict=False)):
        return ("envelope_torque_nm", f"{torques} is not monotone",
                "positive torques that do not rise with speed")
    return None


def largest_torque_nm(speed_rpm, top_nm: float, base_speed_rpm: float | None = None,
                      speeds_rpm=None, torques_nm=None) -> np.ndarray:
    """The largest torque [N m] at ``speed_rpm`` (either sign) of an envelope (a base speed,
    or a table linear between its points and flat beyond the last) capped by ``top_nm``;
    ``top_nm`` alone without an envelope."""
    speed = np.abs(np.asarray(speed_rpm, dtype=float))
    if base_speed_rpm is not None:
        return np.minimum(top_nm, top_nm * base_speed_rpm / np.maximum(speed, 1e-12))
    if speeds_rpm is not None:
        return np.minimum(np.interp(speed, speeds_rpm, torques_nm), top_nm)
    return np.full(speed.shape, float(top_nm))
