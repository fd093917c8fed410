"""``session.toml``: the metadata of one bench session (docs/schemas.md section 1)."""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from dataclasses import dataclass, replace
from datetime import date, datetime
from pathlib import Path, PurePath

from bench.store.schema import STAGING_PREFIX
from kernel.errors import InputError
from kernel.files import bad_number_at, read_toml

SESSION_FILE = "session.toml"


@dataclass(frozen=True)
class Session:
    """A parsed, validated ``session.toml``.

    Parameters
    ----------
    folder : Path
        The session folder.
    session_id : str
        Equals the folder name.
    kind : str
        ``"timeseries"``, ``"operating_points"`` or ``"cycle_run"`` (a drive profile
        flown, ``[cycle] profile``: cut into cycles, not steady windows).
    mode : str
        Intended bench mode, ``"motor"`` or ``"generator"`` (``"cycle"`` for a cycle run).
    gear_ratio : float
        Motor-shaft speed / drum-shaft speed [-].
    measured_side : str
        ``"drum"`` or ``"motor"``.
    speed_sign, torque_sign : int
        +1 or -1: logged value times sign = drum frame (``torque_sign = "signed"``
        in the file gives +1 here and ``signed_torque``).
    ranges : dict
        Sensor ranges ``speed`` [rpm], ``torque`` [N m], ``power`` [W].
    raw : dict
        The whole file, for the manifest.
    signed_torque : bool
        ``torque_sign = "signed"``: the bench logs torque < 0 in generator mode;
        speed and torque are flipped where torque < 0 (drum frame: torque >= 0).
    """

    folder: Path
    session_id: str
    kind: str
    mode: str
    gear_ratio: float
    measured_side: str
    speed_sign: int
    torque_sign: int
    ranges: dict
    raw: dict
    signed_torque: bool = False

    @property
    def single_stream(self) -> bool:
        """A timeseries session with one ``[log]`` file instead of ``[daq]`` + ``[analyzer]``."""
        return self.kind in ("timeseries", "cycle_run") and "log" in self.raw

    def profile(self) -> Path:
        """A cycle run's drive profile (``[cycle] profile``, in the session folder)."""
        name = self.table("cycle").get("profile")
        if not isinstance(name, str) or not name:
            raise InputError(self.path, "[cycle] has no 'profile'", column="cycle.profile",
                             expected="the drive profile's file name in the session folder")
        return self.inside(name, "cycle.profile")

    def day(self) -> date | None:
        """The session's ``date`` (dates a time-of-day time column), or None."""
        value = self.raw.get("date")
        if value is None or isinstance(value, date) and not isinstance(value, datetime):
            return value
        if isinstance(value, datetime):
            return value.date()
        try:
            return date.fromisoformat(str(value).strip())
        except ValueError as exc:
            raise InputError(self.path, f"bad date {value!r}", column="date",
                             expected="an ISO date, e.g. 2013-04-17") from exc

    @property
    def path(self) -> Path:
        """The ``session.toml`` file."""
        return self.folder / SESSION_FILE

    def table(self, name: str) -> dict:
        """A sub-table (``daq``, ``analyzer``, ``points``); InputError when missing."""
        t = self.raw.get(name)
        if not isinstance(t, dict):
            raise InputError(self.path, f"missing table [{name}]",
                             expected=f"a [{name}] table for kind = {self.kind!r}")
        return t

    def file(self, table: str) -> Path:
        """The data file a sub-table names, which must exist in the session folder."""
        name = self.table(table).get("file")
        if not isinstance(name, str) or not name:
            raise InputError(self.path, f"[{table}] has no 'file'", column=f"{table}.file",
                             expected="a file name in the session folder")
        return self.inside(name, f"{table}.file")

    def inside(self, name: str, key: str) -> Path:
        """A file named in session.toml, which must exist inside the session folder.

        Absolute names, names climbing out (``..``) and symbolic links that lead
        out of the session folder are refused before the file is opened.

        Raises
        ------
        InputError
            Naming ``key``; the target's content is never read or echoed.
        """
        where = f"a file in {self.folder}"
        rel = PurePath(name)
        if rel.is_absolute() or rel.drive or ".." in rel.parts or "\\" in name:
            raise InputError(self.path, f"file {name!r} is outside the session folder",
                             column=key, expected=f"a plain relative name, {where}")
        path = self.folder / rel
        if not path.is_file():
            raise InputError(self.path, f"file {name!r} does not exist", column=key,
                             expected=where)
        if not path.resolve().is_relative_to(self.folder.resolve()):
            raise InputError(self.path, f"file {name!r} is a link out of the session folder",
                             column=key, expected=where)
        return path

    def daq_start(self) -> datetime | None:
        """Wall time of the DAQ clock's time 0, when given."""
        text = self.table("daq").get("start")
        if text is None:
            return None
        try:
            return datetime.fromisoformat(str(text))
        except ValueError as exc:
            raise InputError(self.path, f"bad [daq] start {text!r}", column="daq.start",
                             expected="ISO 8601 date-time, e.g. 2013-04-17T09:12:03.250") from exc


def _get(path: Path, raw: dict, key: str, types, allowed=None):
    if key not in raw:
        raise InputError(path, f"missing key {key!r}", column=key)
    value = raw[key]
    if not isinstance(value, types) or isinstance(value, bool):
        raise InputError(path, f"bad value {value!r} for {key!r}", column=key,
                         expected=getattr(types, "__name__", str(types)))
    if allowed is not None and value not in allowed:
        raise InputError(path, f"bad value {value!r} for {key!r}", column=key,
                         expected=" or ".join(repr(a) for a in allowed))
    return value


#: ``[sensors]`` keys and the drive-rating key (drum side) each defaults from
RANGE_KEYS = {"speed_range_rpm": "max_speed_rpm", "torque_range_nm": "max_torque_nm",
              "power_range_w": "nominal_power_w"}
#: a sensor range the session does not state: the drive's rating times this (a sensor
#: sized a quarter above the rating it measures, as the synthetic rated-drive campaign's)
RANGE_OVER_RATING = 1.25
#: the last resort when neither ``[sensors]`` nor a drive rating gives a range: the shipped
#: synthetic campaign's drum-side sensors [rpm, N m, W], used as scales only (tare
#: standstill, steady-window floor), never to reject a point, and said by ``bench ingest``
ASSUMED_RANGES = {"speed": 3000.0, "torque": 100.0, "power": 15000.0}


def _sensor_ranges(path: Path, sensors) -> dict[str, float | None]:
    """``[sensors]`` ranges as finite positive floats (None for an absent key).

    Raises
    ------
    InputError
        ``sensors`` not a table, or a range that is not a finite positive number.
    """
    if not isinstance(sensors, dict):
        raise InputError(path, f"bad value {sensors!r} for 'sensors'", column="sensors",
                         expected="a [sensors] table, e.g. torque_range_nm = 100.0")
    out = {}
    for key in RANGE_KEYS:
        value = sensors.get(key)
        if value is not None and (isinstance(value, bool) or not isinstance(value, int | float)
                                  or not math.isfinite(value) or value <= 0):
            raise InputError(path, f"bad sensor range {value!r}", column=f"sensors.{key}",
                             expected="a finite positive number (the sensor's full scale)")
        out[key.split("_")[0]] = None if value is None else float(value)
    return out


def complete_ranges(session: Session, rating: dict | None) -> tuple[Session, str | None]:
    """The session with every sensor range: the stated ones, the others from the drive rating.

    A range ``[sensors]`` does not state is :data:`RANGE_OVER_RATING` times the drive's
    rating (``drive.toml`` or the session's own rating keys; drum side, carried to the
    measured shaft through the gear ratio).

    Returns
    -------
    (Session, str or None)
        The completed session and a line saying which ranges were derived (None when
        every range was stated).

    A range neither stated nor in a drive rating is :data:`ASSUMED_RANGES`' (drum side),
    and the line says that none was given and which keys to write.
    """
    ranges = dict(session.ranges)
    derived, assumed = [], []
    for key, rating_key in RANGE_KEYS.items():
        q = key.split("_")[0]
        if ranges[q] is not None:
            continue
        value = (rating or {}).get(rating_key)
        into = derived if value is not None else assumed
        if value is None:
            value = ASSUMED_RANGES[q] / RANGE_OVER_RATING
        if session.measured_side == "motor" and q == "speed":
            value *= session.gear_ratio
        elif session.measured_side == "motor" and q == "torque":
            value /= session.gear_ratio
        ranges[q] = RANGE_OVER_RATING * value
        into.append(f"{key} = {ranges[q]:g}")
    lines = []
    if derived:
        lines.append(f"{', '.join(derived)} taken as {RANGE_OVER_RATING:g} x the drive rating")
    if assumed:
        lines.append(f"no sensor range and no drive rating given for "
                     f"{', '.join(a.split(' =')[0] for a in assumed)}: assumed "
                     f"{', '.join(assumed)} (scales only, no point is checked against them; "
                     "write them in [sensors] or the rating in drive.toml)")
    if not lines:
        return session, None
    return (replace(session, ranges=ranges),
            f"session {session.session_id}: " + "; ".join(lines))


def load_session(folder: str | Path) -> Session:
    """Read and validate ``<folder>/session.toml``.

    Raises
    ------
    InputError
        Unparsable TOML, a missing key, a bad value, or a ``session_id`` that is
        not the folder name.
    """
    folder = Path(folder)
    path = folder / SESSION_FILE
    if not path.resolve().is_relative_to(folder.resolve()):
        raise InputError(path, f"{SESSION_FILE} is a link out of the session folder "
                         f"(to {path.resolve()})", expected=f"a {SESSION_FILE} in {folder}")
    raw = read_toml(path)
    bad = bad_number_at(raw)  # NaN, inf, or an integer no float holds, in any key
    if bad is not None and not bad[1].startswith("non-finite"):
        raise InputError(path, bad[1], column=bad[0], expected="a number of usual size")
    sid = _get(path, raw, "session_id", str)
    if sid != folder.name:
        raise InputError(path, f"session_id {sid!r} differs from the folder name",
                         column="session_id", expected=repr(folder.name))
    kind = _get(path, raw, "kind", str, ("timeseries", "operating_points", "cycle_run"))
    mode = _get(path, raw, "mode", str,
                ("cycle",) if kind == "cycle_run" else ("motor", "generator"))
    gear = float(_get(path, raw, "gear_ratio", (int, float)))
    if not (math.isfinite(gear) and gear > 0):
        raise InputError(path, f"gear_ratio {gear} is not a finite positive number",
                         column="gear_ratio", expected="motor-shaft / drum-shaft speed, > 0")
    side = _get(path, raw, "measured_side", str, ("drum", "motor"))
    ssign = _get(path, raw, "speed_sign", int, (1, -1))
    signed = raw.get("torque_sign") == "signed"
    tsign = 1 if signed else _get(path, raw, "torque_sign", int, (1, -1))
    if kind in ("timeseries", "cycle_run"):
        _check_streams(path, raw)
    ranges = _sensor_ranges(path, raw.get("sensors", {}))
    if bad is not None:  # the keys checked above said so in their own words
        raise InputError(path, bad[1], column=bad[0], expected="finite numbers")
    return Session(folder=folder, session_id=sid, kind=kind, mode=mode, gear_ratio=gear,
                   measured_side=side, speed_sign=ssign, torque_sign=tsign, ranges=ranges, raw=raw,
                   signed_torque=signed)


def _check_streams(path: Path, raw: dict) -> None:
    """A timeseries session names either one ``[log]`` or a ``[daq]`` and an ``[analyzer]``."""
    has = {t for t in ("log", "daq", "analyzer") if t in raw}
    if has == {"log"} or has == {"daq", "analyzer"}:
        return
    if "log" in has:
        raise InputError(path, f"both [log] and {sorted(has - {'log'})} given", column="log",
                         expected="either one [log] file (time, speed, torque, p_elec on one "
                         "clock) or a [daq] and an [analyzer] file")
    missing = sorted({"daq", "analyzer"} - has)
    raise InputError(path, f"missing table [{missing[0]}]", column=missing[0],
                     expected="a [daq] and an [analyzer] table, or one [log] table, "
                     "for kind = 'timeseries'")


def discover(paths: list[str | Path],
             notify: Callable[[str], None] | None = None) -> list[Path]:
    """Session folders (holding ``session.toml``) at or under each path, sorted, unique.

    Symbolic links are followed only while they stay inside the given path, and
    each real folder is walked once (a link cycle ends). A link out of the given
    path is skipped and ``notify`` told which and where it leads.

    Raises
    ------
    InputError
        A path that does not exist, or no session anywhere.
    """
    found: set[Path] = set()
    for p in map(Path, paths):
        if not p.exists():
            raise InputError(p, "no such file or directory",
                             expected="a campaign or session folder")
        if p.is_file():
            p = p.parent if p.name == SESSION_FILE else p
        root = p.resolve()
        visited: set[Path] = set()
        for folder, dirs, names in os.walk(p, followlinks=True):
            real = Path(folder).resolve()
            # a link out of the campaign, or back to a folder already walked (a cycle)
            if real in visited or not real.is_relative_to(root):
                if notify is not None and not real.is_relative_to(root):
                    notify(f"bench ingest: skipped {folder}: a link out of {p} (to {real})")
                dirs[:] = []
                continue
            visited.add(real)
            dirs[:] = sorted(d for d in dirs if not d.startswith(STAGING_PREFIX))
            if SESSION_FILE in names:
                found.add(Path(os.path.abspath(folder)))
    if not found:
        raise InputError(paths[0] if paths else None, "no session folders found",
                         expected=f"folders holding a {SESSION_FILE}")
    return sorted(found)
