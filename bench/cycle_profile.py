"""The drive-profile file: a cycle as a bench runs it (docs/schemas.md §10).

``bench cycle export`` writes it, ``bench synth --cycle-run`` flies it on the synthetic
bench and ``bench ingest`` cuts a cycle-run session into cycles against it, so its one
reader and one writer live here, below all three.

The file is CSV: header lines ``# key = value`` (a TOML document once the leading ``#``
is stripped; lines starting ``##`` are comments), then the column names and one row per
set-point. The set-points are in the bench's frame, which the header states with the
keys of ``session.toml`` (``measured_side``, ``gear_ratio``, ``speed_sign``,
``torque_sign``): ``drum value = bench value x sign``, and on the motor side speed over
the gear ratio and torque times it. Beside it, two plain two-column tables (time and one
set-point, no header) for bench controllers that import those: ``<stem>.speed.csv`` and
``<stem>.torque.csv``.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from kernel.errors import InputError
from kernel.files import (
    atomic_path,
    bad_number_at,
    file_sha256,
    parse_toml,
    read_text,
)
from kernel.units import RPM_PER_RAD_S

SCHEMA_NAME = "drivebench.drive_profile"
SCHEMA_VERSION = 1
TITLE = "## drivebench drive profile (docs/schemas.md section 10)"
COLUMNS = ("time_s", "speed_set_rpm", "torque_set_nm", "p_elec_pred_w", "p_mech_pred_w",
           "cycle")
#: the header keys every profile states (more are kept as given)
REQUIRED_KEYS = ("schema", "schema_version", "scenario", "measured_side", "gear_ratio",
                 "speed_sign", "torque_sign", "rate_hz", "period_s", "n_cycles",
                 "cycle_start_s", "e_elec_pred_j", "e_mech_pred_j")
#: the profile's own mechanical energy per cycle (its set-points integrated) may differ
#: from the optimizer's by this share (the export's interpolation and the file's rounding
#: leave 0.02 %)
E_MECH_RTOL = 5e-3
#: the header keys that say which sweep, power model and trajectory the cycle is
#: (``bench ingest`` keeps them with the session; ``bench cycle verify`` checks them)
PROVENANCE_KEYS = ("optimize_run_id", "power_model_sha256", "trajectory_sha256")
#: the units a header may state for the columns (their names say rpm, N m, W)
UNITS = {"speed_unit": ("rpm", "1/min", "min^-1"), "torque_unit": ("N m", "Nm", "N*m", "N.m"),
         "power_unit": ("W",)}
#: header keys that must be whole numbers
INTEGER_KEYS = ("schema_version", "n_cycles", "speed_sign", "torque_sign")
SIGN_CONVENTION = ("p_elec_pred_w > 0 drawn from the grid; p_mech_pred_w > 0 delivered by the "
                   "drive to the shaft; drum frame: torque >= 0, reel-out (generating) speed < 0")
_EXPECTED = "a drive profile written by bench cycle export (docs/schemas.md section 10)"


@dataclass(frozen=True)
class BenchFrame:
    """How the bench's speed and torque relate to the drum frame (as in ``session.toml``).

    Parameters
    ----------
    measured_side : str
        ``"drum"`` or ``"motor"``: the shaft the set-points are for.
    gear_ratio : float
        Motor-shaft speed / drum-shaft speed [-].
    speed_sign, torque_sign : int
        +1 or -1: drum value = bench value x sign (after the gear conversion).
    """

    measured_side: str = "drum"
    gear_ratio: float = 1.0
    speed_sign: int = 1
    torque_sign: int = 1

    def __post_init__(self) -> None:
        if self.measured_side not in ("drum", "motor"):
            raise ValueError(f"measured_side {self.measured_side!r}: 'drum' or 'motor'")
        if not (math.isfinite(self.gear_ratio) and self.gear_ratio > 0):
            raise ValueError(f"gear_ratio {self.gear_ratio}: a finite positive number")
        if self.speed_sign not in (1, -1) or self.torque_sign not in (1, -1):
            raise ValueError("speed_sign and torque_sign are +1 or -1")

    @property
    def _gear(self) -> float:
        return self.gear_ratio if self.measured_side == "motor" else 1.0

    def to_bench(self, speed_rpm, torque_nm):
        """Drum-frame speed [rpm] and torque [N m] -> the bench's."""
        return (np.asarray(speed_rpm, float) * self._gear * self.speed_sign,
                np.asarray(torque_nm, float) / self._gear * self.torque_sign)

    def to_drum(self, speed_rpm, torque_nm):
        """The bench's speed [rpm] and torque [N m] -> the drum frame."""
        return (np.asarray(speed_rpm, float) / self._gear * self.speed_sign,
                np.asarray(torque_nm, float) * self._gear * self.torque_sign)

    def keys(self) -> dict:
        """The ``session.toml`` keys of this frame."""
        return {"measured_side": self.measured_side, "gear_ratio": float(self.gear_ratio),
                "speed_sign": self.speed_sign, "torque_sign": self.torque_sign}


@dataclass(frozen=True)
class DriveProfile:
    """A drive profile: its header and its set-point columns.

    Parameters
    ----------
    header : dict
        The header keys (:data:`REQUIRED_KEYS` and more: limits, provenance, ...).
    columns : dict of numpy.ndarray
        :data:`COLUMNS`: time [s], speed and torque set-points in the bench frame
        [rpm, N m], the predicted electrical and mechanical power [W] and the cycle
        index (-1 on the standstill and the ramps).
    """

    header: dict
    columns: dict = field(repr=False)

    @property
    def frame(self) -> BenchFrame:
        """The bench frame the set-points are in."""
        h = self.header
        return BenchFrame(h["measured_side"], float(h["gear_ratio"]), int(h["speed_sign"]),
                          int(h["torque_sign"]))

    @property
    def period_s(self) -> float:
        """Cycle period [s]."""
        return float(self.header["period_s"])

    @property
    def n_cycles(self) -> int:
        """Number of cycles the profile repeats."""
        return int(self.header["n_cycles"])

    def drum(self) -> tuple[np.ndarray, np.ndarray]:
        """The set-points in the drum frame: speed [rpm], torque [N m]."""
        return self.frame.to_drum(self.columns["speed_set_rpm"], self.columns["torque_set_nm"])

    def e_mech_cycles_j(self) -> np.ndarray:
        """The set-points' mechanical energy over each cycle [J] (speed x torque
        integrated, trapezoids)."""
        speed, torque = self.drum()
        t = self.columns["time_s"]
        return cycle_integrals(t, speed * torque / RPM_PER_RAD_S,
                               float(self.header["cycle_start_s"]), self.period_s,
                               self.n_cycles)

    def one_cycle(self) -> dict[str, np.ndarray]:
        """The rows of cycle 0, time measured from the cycle's start [s]."""
        sel = self.columns["cycle"] == 0
        out = {k: v[sel] for k, v in self.columns.items()}
        out["time_s"] = out["time_s"] - float(self.header["cycle_start_s"])
        return out


def _toml_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(str(k))} = {_toml_value(v)}"
                               for k, v in value.items()) + "}"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, float):
        if not math.isfinite(value):
            raise ValueError(f"non-finite header value {value}")
        return repr(value)
    if isinstance(value, int):
        return str(value)
    return json.dumps(str(value), ensure_ascii=False)


def header_text(header: dict) -> str:
    """The header lines of a profile (title, then ``# key = value``)."""
    return "\n".join([TITLE, *(f"# {k} = {_toml_value(v)}" for k, v in header.items())]) + "\n"


def _rows(columns: list[np.ndarray], decimals: list[int]) -> str:
    buf = io.StringIO()
    fmt = ",".join(f"%.{d}f" if d else "%d" for d in decimals)
    np.savetxt(buf, np.column_stack(columns), fmt=fmt, delimiter=",")
    return buf.getvalue()


def plain_paths(path: str | Path) -> dict[str, Path]:
    """The two-column tables beside a profile: ``speed`` and ``torque``."""
    path = Path(path)
    stem = path.name[:-4] if path.name.endswith(".csv") else path.name
    return {q: path.with_name(f"{stem}.{q}.csv") for q in ("speed", "torque")}


def _text_sha256(text: str) -> str:
    """SHA-256 of text's lines joined by newlines (the same whatever the line ends)."""
    return hashlib.sha256(("\n".join(text.splitlines()) + "\n").encode("utf-8")).hexdigest()


def write_profile(path: str | Path, profile: DriveProfile) -> dict[str, Path]:
    """Write the two plain tables, then the profile naming them, each atomically.

    The header gets ``speed_table``, ``torque_table`` (the tables' names beside the
    profile) with their ``*_sha256``, and ``body_sha256``. The caller holds the output's
    lock and has checked that the three files may be replaced
    (:func:`check_tables_replaceable`).

    Returns
    -------
    dict of Path
        ``profile``, ``speed``, ``torque``: the files written.
    """
    c = profile.columns
    body = ",".join(COLUMNS) + "\n" + _rows([c[k] for k in COLUMNS], [4, 3, 4, 2, 2, 0])
    tables = {q: _rows([c["time_s"], c[f"{q}_set_{'rpm' if q == 'speed' else 'nm'}"]],
                       [4, 3 if q == "speed" else 4]) for q in ("speed", "torque")}
    paths = plain_paths(path)
    header = {"schema": SCHEMA_NAME, "schema_version": SCHEMA_VERSION, **profile.header,
              **{k: v for q, text in tables.items()
                 for k, v in ((f"{q}_table", paths[q].name),
                              (f"{q}_table_sha256", hashlib.sha256(text.encode()).hexdigest()))},
              "body_sha256": _text_sha256(body)}
    out = {"profile": Path(path), **paths}
    texts = {"speed": tables["speed"], "torque": tables["torque"],
             "profile": header_text(header) + body}
    for key in ("speed", "torque", "profile"):  # the profile last: it names the others
        with atomic_path(out[key]) as tmp:
            tmp.write_bytes(texts[key].encode("utf-8"))
    return out


def check_tables_replaceable(path: str | Path, option: str = "--out") -> None:
    """Raise InputError when a plain table beside the profile ``path`` exists and is not
    the one an earlier export wrote: named in the header of the profile at ``path``
    with that content (its SHA-256).

    Raises
    ------
    InputError
        Naming the table and ``option``: a folder, or a file no earlier export of
        ``path`` wrote (a user's own, or one edited since).
    """
    path = Path(path)
    header = _earlier_header(path)
    for q, table in plain_paths(path).items():
        if table.exists() and not table.is_file():
            raise InputError(table, f"the {q} table's place is not a file (a folder?)",
                             column=option, expected=f"a new profile name, or move {table} "
                             "away")
        if not table.exists():
            continue
        named = header.get(f"{q}_table") == table.name
        if not (named and header.get(f"{q}_table_sha256") == file_sha256(table)):
            why = ("was changed since the export that wrote it" if named else
                   f"was not written by an earlier bench cycle export to {path.name} (its "
                   "header does not name it: a file of your own, or of an older export)")
            raise InputError(table, f"exists and {why}; the export would overwrite it",
                             column=option, expected=f"a new profile name, or move {table} "
                             "away")


def _earlier_header(path: Path) -> dict:
    """The header of the earlier profile at ``path`` ({} when there is none to read)."""
    try:
        with open(path, "rb") as fh:
            if not is_profile(fh.read(len(TITLE))):
                return {}
        return _split(path, read_text(path, what="drive profile"))[0]
    except (OSError, InputError):
        return {}


def is_profile(head: bytes) -> bool:
    """Whether a file's first bytes are those of a drive profile (the ``--out`` rule)."""
    return head.startswith(TITLE.encode())


def _split(path: Path, text: str) -> tuple[dict, int, list[str]]:
    lines = text.splitlines()
    n = 0
    while n < len(lines) and lines[n].startswith("#"):
        n += 1
    if not lines or lines[0] != TITLE:
        raise InputError(path, "not a drive profile (no title line)", line=1,
                         expected=f"{TITLE!r}: {_EXPECTED}")
    toml = "\n".join(line[1:] for line in lines[1:n] if not line.startswith("##"))
    header = parse_toml(toml, path, what="drive profile header")
    return header, n, lines[n:]


def _check_header(path: Path, header: dict) -> None:
    missing = [k for k in REQUIRED_KEYS if k not in header]
    if missing:
        raise InputError(path, f"header key {missing[0]!r} missing", column=missing[0],
                         expected=_EXPECTED)
    bad = bad_number_at(header)
    if bad is not None:
        raise InputError(path, f"header key {bad[0]}: {bad[1]}", column=bad[0],
                         expected="finite numbers in the header")
    if header["schema"] != SCHEMA_NAME or header["schema_version"] != SCHEMA_VERSION:
        raise InputError(path, f"schema {header['schema']!r} version "
                         f"{header['schema_version']!r}", column="schema",
                         expected=f"{SCHEMA_NAME!r} version {SCHEMA_VERSION}")
    for key in INTEGER_KEYS:
        if isinstance(header[key], bool) or not isinstance(header[key], int):
            raise InputError(path, f"{key} = {header[key]!r} is not a whole number",
                             column=key, expected="an integer")
    for key, names in UNITS.items():
        if key in header and header[key] not in names:
            raise InputError(path, f"{key} = {header[key]!r}: the columns are in "
                             f"{names[0]} (their names say so) and are not converted",
                             column=key, expected=f"{names[0]!r} (the columns' unit)")
    try:
        BenchFrame(header["measured_side"], float(header["gear_ratio"]),
                   header["speed_sign"], header["torque_sign"])
    except (ValueError, TypeError) as exc:
        raise InputError(path, f"bad bench frame: {exc}", column="measured_side",
                         expected="the keys of session.toml") from exc
    for key in ("rate_hz", "period_s", "n_cycles"):
        v = header[key]
        if isinstance(v, bool) or not isinstance(v, int | float) or not v > 0:
            raise InputError(path, f"bad value {v!r}", column=key, expected="a positive number")
    for key in ("cycle_start_s", "e_elec_pred_j", "e_mech_pred_j"):
        if isinstance(header[key], bool) or not isinstance(header[key], int | float):
            raise InputError(path, f"{key} = {header[key]!r} is not a number", column=key,
                             expected="a finite number")


def read_profile(path: str | Path) -> DriveProfile:
    """Read and check a drive profile.

    Raises
    ------
    InputError
        Naming the file and the line, key or column: no title, a header key missing
        or bad (not finite, not a whole number, a unit other than the columns'), a
        body other than its ``body_sha256``, a column missing, a value not a finite
        number, time not increasing, or no row of cycle 0.
    """
    path = Path(path)
    header, n_head, body = _split(path, read_text(path, what="drive profile"))
    _check_header(path, header)
    if not body or tuple(body[0].split(",")) != COLUMNS:
        raise InputError(path, "bad column names", line=n_head + 1,
                         expected=",".join(COLUMNS))
    rows = [line for line in body[1:] if line.strip()]
    try:
        data = np.loadtxt(rows, delimiter=",", ndmin=2) if rows else np.empty((0, 6))
    except ValueError as exc:
        raise InputError(path, f"a row that is not {len(COLUMNS)} numbers ({exc})",
                         expected=_EXPECTED) from exc
    if data.shape[1] != len(COLUMNS) or not np.isfinite(data).all():
        bad = int(np.flatnonzero(~np.isfinite(data).all(axis=1))[0]) if data.size else 0
        raise InputError(path, "a row with a missing or non-finite value",
                         line=n_head + 2 + bad, expected="finite numbers")
    cols = {k: data[:, i] for i, k in enumerate(COLUMNS)}
    cols["cycle"] = cols["cycle"].astype(np.int64)
    step = np.diff(cols["time_s"])
    if step.size and step.min() <= 0:
        raise InputError(path, "time does not increase", column="time_s",
                         line=n_head + 3 + int(np.argmin(step)), expected="increasing time")
    if not (cols["cycle"] == 0).any():
        raise InputError(path, "no row of cycle 0", column="cycle", expected=_EXPECTED)
    if "body_sha256" in header and _text_sha256("\n".join(body)) != header["body_sha256"]:
        raise InputError(path, "the set-points (the rows after the header) are not those "
                         "the header's body_sha256 was written for: edited after the export",
                         column="body_sha256", line=n_head + 1,
                         expected="the profile as bench cycle export wrote it (export it "
                         "again)")
    return DriveProfile(header=header, columns=cols)


def window_integral(time_s, values, t0: float, t1: float) -> float:
    """The integral of a sampled signal over ``[t0, t1]`` (trapezoids, the window's ends
    interpolated linearly) [unit of ``values`` x s]; NaN when the samples do not cover it
    or a value inside is not finite."""
    t = np.asarray(time_s, float)
    y = np.asarray(values, float)
    if t.size < 2 or t0 < t[0] or t1 > t[-1] or not t1 > t0:
        return float("nan")
    a, b = np.searchsorted(t, t0, side="right"), np.searchsorted(t, t1, side="left")
    tt = np.concatenate([[t0], t[a:b], [t1]])
    yy = np.concatenate([[np.interp(t0, t, y)], y[a:b], [np.interp(t1, t, y)]])
    return float(np.trapezoid(yy, tt))


def cycle_integrals(time_s, values, t_start: float, period_s: float,
                    n_cycles: int) -> np.ndarray:
    """The integral of a sampled signal over each of ``n_cycles`` cycles from ``t_start``
    (:func:`window_integral`) [unit of ``values`` x s]."""
    return np.array([window_integral(time_s, values, t_start + k * period_s,
                                     t_start + (k + 1) * period_s) for k in range(n_cycles)])
