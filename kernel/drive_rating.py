"""The drive rating of a campaign: nominal power and drum-side speed and torque limits.

A campaign states its drive in a ``drive.toml`` in the campaign folder (or any
folder between it and the session), and a session may state or override keys
at the top level of its ``session.toml``::

    nominal_power_w = 15000.0     # [W], the scale of every %-of-nominal figure (example)
    max_speed_rpm = 3000.0        # [rpm], drum side: the optimizer's default speed limit
    max_torque_nm = 48.0          # [N m], drum side: the optimizer's default torque limit
    source = "datasheet / paper section ..."   # drive.toml only: where the numbers come from
    base_speed_rpm = 1000.0       # drive.toml only, optional: the torque-speed envelope,
                                  # or a table envelope_speed_rpm / envelope_torque_nm
                                  # (kernel.drive_envelope)

``bench ingest`` records what applies to each session in the store manifest;
``bench fit`` writes it into ``power_model.json`` (``drive``); ``bench optimize``
takes its default limits from there. ``bench fit`` checks the measured points against
the envelope; the optimizer flies the envelope its system file states.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

from kernel.drive_envelope import ENVELOPE_KEYS, envelope_problem
from kernel.errors import InputError
from kernel.files import read_toml
from kernel.units import unit_of

#: The rating keys, in drive.toml, session.toml, the manifest and power_model.json.
DRIVE_KEYS = ("nominal_power_w", "max_speed_rpm", "max_torque_nm")
#: Optional rating keys (a system file's ``[drive]``; a carried power model's ``drive``).
OPTIONAL_DRIVE_KEYS = ("continuous_torque_nm", "overload", "max_p_elec_w")
DRIVE_FILE = "drive.toml"


@dataclass(frozen=True)
class DriveRating:
    """A drive's rating (docs/schemas.md §1 ``drive.toml``, §3 ``drive``; docs/system_file.md
    ``[drive]``): the one type every stage reads the drive's limits from.

    Speed and torque are those of the shaft the power model is written for (the
    drum, or the motor behind a gearbox: :class:`optimize.system.system.WinchSection`).

    Parameters
    ----------
    nominal_power_w : float
        Nominal power [W]: the capacity factor's rating and the scale of %-of-nominal figures.
    max_speed_rpm : float
        Largest speed magnitude [rpm].
    max_torque_nm : float
        Largest torque [N m] (the optimizer's torque limit).
    source : str
        Where the numbers come from (file, datasheet, or "measured maxima").
    continuous_torque_nm : float or None
        Continuous (thermal) torque rating [N m]: RMS torque over a cycle at most this.
        None: not stated.
    overload : float or None
        The datasheet's short-time torque over the continuous rating [-] (>= 1), for the
        record: no stage flies it (the torque limit is ``max_torque_nm``). None: not stated.
    max_p_elec_w : float or None
        Largest electrical power magnitude (grid connection) [W]; None: no limit.
    base_speed_rpm : float or None
        Torque-speed envelope: constant power above this speed [rpm]
        (:mod:`kernel.drive_envelope`); None: not stated.
    envelope_speed_rpm, envelope_torque_nm : tuple of float or None
        Torque-speed envelope as a table of speeds [rpm] and largest torques [N m].
    """

    nominal_power_w: float
    max_speed_rpm: float
    max_torque_nm: float
    source: str = ""
    continuous_torque_nm: float | None = None
    overload: float | None = None
    max_p_elec_w: float | None = None
    base_speed_rpm: float | None = None
    envelope_speed_rpm: tuple[float, ...] | None = None
    envelope_torque_nm: tuple[float, ...] | None = None

    def __post_init__(self) -> None:
        for key in (*DRIVE_KEYS, *OPTIONAL_DRIVE_KEYS):
            value = getattr(self, key)
            if key in OPTIONAL_DRIVE_KEYS and value is None:
                continue
            if not _positive(value):
                raise ValueError(f"{key} = {value!r}: a finite positive number "
                                 f"[{unit_of(key) or '-'}] expected")
            object.__setattr__(self, key, float(value))
        if self.overload is not None and self.overload < 1:
            raise ValueError(f"overload = {self.overload!r}: a factor >= 1 expected")
        problem = envelope_problem(self.base_speed_rpm, self.envelope_speed_rpm,
                                   self.envelope_torque_nm)
        if problem is not None:
            raise ValueError("{} = {}: {} expected".format(*problem))
        for key in ENVELOPE_KEYS[1:]:
            if getattr(self, key) is not None:
                object.__setattr__(self, key, tuple(float(v) for v in getattr(self, key)))

    @property
    def envelope(self) -> dict:
        """The envelope keys it states (lists for the table)."""
        return {k: (list(v) if isinstance(v, tuple) else v)
                for k in ENVELOPE_KEYS if (v := getattr(self, k)) is not None}

    def to_dict(self) -> dict:
        """``{nominal_power_w, max_speed_rpm, max_torque_nm, source}`` and the optional
        keys that are stated."""
        optional = {k: getattr(self, k) for k in OPTIONAL_DRIVE_KEYS
                    if getattr(self, k) is not None}
        return {**{k: getattr(self, k) for k in DRIVE_KEYS}, **optional, **self.envelope,
                "source": self.source}

    def line(self) -> str:
        """One line for summaries and reports."""
        extra = "".join(
            f", {label} {getattr(self, key):g} {unit}" for key, label, unit in (
                ("continuous_torque_nm", "continuous", "N m"),
                ("overload", "datasheet overload (not flown)", "x"),
                ("max_p_elec_w", "|P_elec| <=", "W"))
            if getattr(self, key) is not None)
        return (f"drive: {self.nominal_power_w:g} W nominal, |speed| <= {self.max_speed_rpm:g} "
                f"rpm, torque <= {self.max_torque_nm:g} N m{extra} ({self.source})")


def drive_toml(rating: DriveRating) -> str:
    """The ``drive.toml`` text of a rating (read back by :func:`load_drive_file`)."""
    return ("# Drive rating of this campaign (docs/schemas.md section 1): "
            "bench ingest records it,\n"
            "# bench fit writes it into power_model.json, bench optimize takes its limits from "
            "there.\n"
            f"nominal_power_w = {rating.nominal_power_w!r}  # [W]\n"
            f"max_speed_rpm = {rating.max_speed_rpm!r}  # [rpm], drum side\n"
            f"max_torque_nm = {rating.max_torque_nm!r}  # [N m], drum side\n"
            + "".join(f"{k} = {v!r}\n" for k, v in rating.envelope.items())
            + f"source = {_toml_string(rating.source)}\n")


def _toml_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _finite(value) -> bool:
    return (isinstance(value, (int, float)) and not isinstance(value, bool)
            and math.isfinite(value))


def _positive(value) -> bool:
    return _finite(value) and value > 0


def rating_keys(table: dict, path: Path | str | None) -> dict[str, float]:
    """The rating keys a TOML table states, checked (a positive finite number each).

    Raises
    ------
    InputError
        A key with a value that is not a positive finite number (naming file and key).
    """
    out = {}
    for key in DRIVE_KEYS:
        if key in table:
            value = table[key]
            if not _positive(value):
                raise InputError(path, f"bad value {value!r}", column=key,
                                 expected=f"a positive number [{unit_of(key) or '-'}]")
            out[key] = float(value)
    return out


def load_drive_file(path: str | Path) -> dict:
    """Read a ``drive.toml``: its rating keys and ``source``.

    Raises
    ------
    InputError
        Unreadable or invalid TOML, a bad value, an unknown key, or no rating key.
    """
    path = Path(path)
    raw = read_toml(path)
    for key in raw:
        if key not in (*DRIVE_KEYS, *ENVELOPE_KEYS, "source"):
            raise InputError(path, f"unknown key {key!r}", column=key,
                             expected=", ".join((*DRIVE_KEYS, *ENVELOPE_KEYS, "source")))
    keys = rating_keys(raw, path)
    if not keys:
        raise InputError(path, "no drive rating", expected="at least one of "
                         + ", ".join(DRIVE_KEYS))
    source = raw.get("source", "")
    if not isinstance(source, str):
        raise InputError(path, f"bad value {source!r}", column="source", expected="a string")
    return {**keys, **envelope_keys(raw, path), "source": source}


def envelope_keys(table: dict, path: Path | str | None) -> dict:
    """The torque-speed envelope a TOML table states (:mod:`kernel.drive_envelope`),
    checked; lists for the table.

    Raises
    ------
    InputError
        A value that is not a number (or a list of numbers), or an envelope that is not
        one (naming file and key).
    """
    out = {k: table[k] for k in ENVELOPE_KEYS if k in table}
    for key, value in out.items():
        scalar = key == "base_speed_rpm"
        values = [value] if scalar else value
        if not isinstance(values, list) or not all(_finite(v) for v in values):
            raise InputError(path, f"bad value {value!r}", column=key,
                             expected="a number [rpm]" if scalar else "a list of numbers")
    problem = envelope_problem(out.get("base_speed_rpm"), out.get("envelope_speed_rpm"),
                               out.get("envelope_torque_nm"))
    if problem is not None:
        key, what, expected = problem
        raise InputError(path, f"bad value {what}", column=key, expected=expected)
    return out


def find_drive_file(session_folder: Path, roots: list[Path]) -> Path | None:
    """The nearest ``drive.toml`` at or above a session folder, not above its campaign root.

    Parameters
    ----------
    session_folder : Path
        The session folder (holding ``session.toml``).
    roots : list of Path
        The folders ``bench ingest`` was given; the search stops at the one that
        contains the session (or at the session's parent when none does).
    """
    folder = session_folder.resolve()
    resolved = [r.resolve() for r in roots]
    stops = [r if r.is_dir() else r.parent for r in resolved]
    stop = next((r for r in stops if folder == r or r in folder.parents), folder.parent)
    for candidate in (folder, *folder.parents):
        if (candidate / DRIVE_FILE).is_file():
            return candidate / DRIVE_FILE
        if candidate == stop:
            break
    return None


def session_drive(session_raw: dict, session_path: Path, drive_file: Path | None,
                  label: str) -> dict | None:
    """The drive rating that applies to one session, with where each key came from.

    Parameters
    ----------
    session_raw : dict
        The parsed ``session.toml`` (its top-level rating keys win).
    session_path : Path
        The ``session.toml`` file, named in errors.
    drive_file : Path or None
        The campaign's ``drive.toml`` (:func:`find_drive_file`).
    label : str
        How ``drive_file`` is named in the result (e.g. its path in the campaign).

    Returns
    -------
    dict or None
        ``{key: value, ..., "sources": {key: file}, "source": text}`` for the keys
        stated anywhere, or None when neither file states any.
    """
    out: dict = {}
    sources: dict[str, str] = {}
    note = ""
    if drive_file is not None:
        data = load_drive_file(drive_file)
        note = data.pop("source")
        out.update(data)
        sources.update(dict.fromkeys(data, label))
    own = rating_keys(session_raw, session_path)
    out.update(own)
    sources.update(dict.fromkeys(own, f"{session_path.parent.name}/{session_path.name}"))
    if not out:
        return None
    return {**out, "sources": sources, "source": note}
