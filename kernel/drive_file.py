"""A campaign's ``drive.toml``: the drive rating (:class:`kernel.drive.Drive`) its sessions
were measured with, read and written.

A campaign states its drive in a ``drive.toml`` in the campaign folder (or any
folder between it and the session), and a session may state or override keys
at the top level of its ``session.toml``::

    nominal_power_w = 15000.0     # [W], the scale of every %-of-nominal figure (example)
    max_speed_rpm = 3000.0        # [rpm], drum side: the optimizer's default speed limit
    max_torque_nm = 48.0          # [N m], drum side: the optimizer's default torque limit
    source = "datasheet / paper section ..."   # drive.toml only: where the numbers come from
    base_speed_rpm = 1000.0       # drive.toml only, optional: the torque-speed envelope,
                                  # or a table envelope_speed_rpm / envelope_torque_nm
                                  # (kernel.drive)

``bench ingest`` records what applies to each session in the store manifest;
``bench fit`` writes it into ``power_model.json`` (``drive``); ``bench optimize``
takes its default limits from there. ``bench fit`` checks the measured points against
the envelope; the optimizer flies the envelope its system file states.
"""

from __future__ import annotations

from pathlib import Path

from kernel.drive import DRIVE_KEYS, ENVELOPE_KEYS, Drive, envelope_problem, finite_number
from kernel.errors import InputError
from kernel.files import read_toml
from kernel.units import unit_of

DRIVE_FILE = "drive.toml"


def drive_toml(rating: Drive) -> str:
    """The ``drive.toml`` text of a rating (read back by :func:`load_drive_file`)."""
    return ("# Drive rating of this campaign (docs/schemas.md section 1): "
            "bench ingest records it,\n"
            "# bench fit writes it into power_model.json, bench optimize takes its limits from "
            "there.\n"
            f"nominal_power_w = {rating.nominal_power_w!r}  # [W]\n"
            f"max_speed_rpm = {rating.max_speed_rpm!r}  # [rpm], drum side\n"
            f"max_torque_nm = {rating.max_torque_nm!r}  # [N m], drum side\n"
            + "".join(f"{k} = {v!r}\n" for k, v in rating.envelope.items())
            + f"source = {_toml_string(rating.source or '')}\n")


def _toml_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _positive(value) -> bool:
    return finite_number(value) and value > 0


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
    """The torque-speed envelope a TOML table states (:class:`kernel.drive.Drive`),
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
        if not isinstance(values, list) or not all(finite_number(v) for v in values):
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
