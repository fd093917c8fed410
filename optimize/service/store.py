"""Finished solves stored under the hash of their inputs, so a re-run resumes.

``<key>.json`` holds a solve's record, ``<key>.npz`` its primal and dual vectors
(the next solve's warm start), each written whole (:func:`kernel.files.atomic_write`).

Nothing stored is believed unchecked (:func:`read_solve`). The record carries a block
``"store"``: the file format, the key of the problem it solves (:func:`solve_key`),
the SHA-256 of the record's own content and the size and SHA-256 of its ``.npz``.
A record whose content or ``.npz`` differs from those hashes (an edit, a truncated or
swapped file), that solves another problem or speed, that is no record at all, or
whose figures contradict each other (a converged solve without a finite power, a
failed one with a power) is not used: :func:`read_solve` says which file and why, and
the solve service solves that scenario again and stores the new solve over it.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from kernel.files import atomic_path, dumps_json, file_sha256, recorded_mismatch, write_json
from optimize.problem.scenario import Scenario

#: bump when the meaning of a stored solve changes (invalidates every stored solve)
STORE_VERSION = 1
#: the form of the stored files (the ``"store"`` block); a record of another form is
#: solved again, saying so
FILE_FORMAT = 2
#: a record is a few kB; a larger ``.json`` is no record (read no further)
MAX_RECORD_BYTES = 1 << 20
#: the arrays of a warm start's ``.npz``
WARM_ARRAYS = ("w", "lam_x", "lam_g")


def solve_key(problem: Any, scenario: Scenario) -> str:
    """SHA-256 (hex) of everything one solve depends on: the drive model's hash, the OCP
    options, the scenario's wind speed, objective and limits, the system's hash and its
    drive in force (when the problem has a system).

    ``problem`` is an :class:`optimize.service.builder.Problem`.
    """
    data = {"version": STORE_VERSION, "model": problem.drive_model.sha256,
            "options": dataclasses.asdict(problem.options),
            "wind_speed_m_s": float(scenario.wind_speed_m_s),
            "objective": scenario.objective, "drive_limits": bool(scenario.drive_limits)}
    if problem.system is not None:
        data["system"] = problem.system.sha256
        data["drive_in_force"] = problem.system.drive_key()
    text = json.dumps(data, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()


@dataclasses.dataclass(frozen=True)
class StoredSolve:
    """What the store holds of one solve.

    Attributes
    ----------
    record : dict or None
        The solve's record when its files passed every check; None when they did not.
    warm : Solution or None
        Its warm start (None when it has none, or the record was not believed).
    rejected : str or None
        Which file was not believed and why (``"size_out/solves/<key>.json: its content
        differs from the SHA-256 it records (edited or damaged)"``); None when believed.
    """

    record: dict | None
    warm: Any = None
    rejected: str | None = None


class _Damage(Exception):
    """A stored file that is not believed: the file and why."""

    def __init__(self, path: Path, why: str) -> None:
        super().__init__(f"{path}: {why}")


def record_sha256(record: dict) -> str:
    """SHA-256 (hex) of a record's content: its JSON with sorted keys, as read back."""
    text = json.dumps(record, sort_keys=True, separators=(",", ":"), allow_nan=True)
    return hashlib.sha256(text.encode()).hexdigest()


def read_solve(store: Path, key: str, scenario: Scenario | None = None
               ) -> StoredSolve | None:
    """The stored solve of ``key`` (checked, see the module docstring), or None when the
    store holds none.

    Parameters
    ----------
    store : Path
        Folder of the stored solves.
    key : str
        The solve's key (:func:`solve_key`).
    scenario : Scenario, optional
        The scenario the key stands for: a record of another is not believed.

    Returns
    -------
    StoredSolve or None
        None when there is no ``<key>.json`` (a ``.npz`` alone is what a run stopped
        between its two writes leaves); else the record and warm start, or why not.
    """
    js, npz = Path(store) / f"{key}.json", Path(store) / f"{key}.npz"
    if not (js.exists() or js.is_symlink()):
        return None
    try:
        rec, npz_record = _read_record(js, key)
        _check_figures(js, rec, scenario)
        warm = None if npz_record is None else _read_warm(npz, npz_record)
    except _Damage as damage:
        return StoredSolve(None, None, str(damage))
    return StoredSolve(rec, warm)


def load_solve(store: Path, key: str) -> tuple[dict, Any] | None:
    """A stored solve (its record, its warm start or None) or None when absent or not
    believed (:func:`read_solve`)."""
    stored = read_solve(store, key)
    if stored is None or stored.record is None:
        return None
    return stored.record, stored.warm


def rejected_lines(records: Any) -> list[str]:
    """One line per solve record whose stored files were not believed (its
    ``store_rejected``: the file and why), so it was solved again: ``"stored solve not
    used: size_out/solves/<key>.json: its content differs ...; x2 elec-lim 8 m/s solved
    again"``."""
    lines = []
    for r in records:
        if r.get("store_rejected"):
            who = f"{r['candidate']} " if r.get("candidate") else ""
            lines.append(f"stored solve not used: {r['store_rejected']}; {who}{r['kind']} "
                         f"{float(r['wind_speed_m_s']):g} m/s solved again")
    return lines


def _read_record(js: Path, key: str) -> tuple[dict, dict | None]:
    """The record of ``js`` (its ``"store"`` block checked and removed) and its ``.npz``'s
    size and hash (None: stored without a warm start)."""
    if not js.is_file():
        raise _Damage(js, "not a regular file")
    try:
        size = js.stat().st_size
        if size > MAX_RECORD_BYTES:
            raise _Damage(js, f"{size} bytes: no solve record (those are a few kB)")
        rec = json.loads(js.read_bytes().decode("utf-8"))
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise _Damage(js, f"unreadable ({type(exc).__name__}: {exc}); truncated or "
                          "not written by drivebench") from None
    block = rec.pop("store", None) if isinstance(rec, dict) else None
    if not isinstance(block, dict):
        raise _Damage(js, "records no content hash (written by an earlier drivebench or "
                          "another program)")
    if block.get("format") != FILE_FORMAT:
        raise _Damage(js, f"stored in format {block.get('format')!r}, this drivebench "
                          f"reads {FILE_FORMAT}")
    if block.get("record_sha256") != record_sha256(rec):
        raise _Damage(js, "its content differs from the SHA-256 it records (edited or "
                          "damaged)")
    if block.get("key") != key or rec.get("key") != key:
        raise _Damage(js, f"holds the solve of another problem (key "
                          f"{str(block.get('key'))[:12]}, its file name says {key[:12]})")
    npz_record = block.get("npz")
    if npz_record is not None and not isinstance(npz_record, dict):
        raise _Damage(js, "its record of the .npz is no size and SHA-256")
    return rec, npz_record


def _finite(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool) and math.isfinite(value)


def _check_figures(js: Path, rec: dict, scenario: Scenario | None) -> None:
    """Refuse a record of another scenario, or whose figures contradict each other."""
    if scenario is not None and rec.get("kind") != scenario.kind:
        raise _Damage(js, f"holds kind {rec.get('kind')!r}, not {scenario.kind!r}")
    if scenario is not None and not (
            _finite(rec.get("wind_speed_m_s"))
            and float(rec["wind_speed_m_s"]) == scenario.wind_speed_m_s):
        raise _Damage(js, f"holds wind speed {rec.get('wind_speed_m_s')!r}, not "
                          f"{scenario.wind_speed_m_s:g} m/s")
    if not isinstance(rec.get("success"), bool) or not isinstance(rec.get("status"), str):
        raise _Damage(js, "its success or status is missing or not a boolean and a text")
    power = rec.get("avg_p_elec_w")
    if rec["success"] and not _finite(power):
        raise _Damage(js, f"a converged solve without a finite avg_p_elec_w ({power!r})")
    if not rec["success"] and power is not None:
        raise _Damage(js, f"a failed solve with avg_p_elec_w {power!r}")
    period = rec.get("period_s")
    if rec["success"] and period is not None and not (_finite(period) and period > 0):
        raise _Damage(js, f"a converged solve with period_s {period!r}")


def _read_warm(npz: Path, recorded: dict) -> Any:
    """The warm start of ``npz``, checked against its recorded size and SHA-256."""
    from optimize.solve.result import Solution

    why = ("not a regular file" if npz.exists() and not npz.is_file()
           else recorded_mismatch(npz, recorded))
    if why is not None:
        raise _Damage(npz, f"not the warm start its record lists ({why})")
    try:
        with np.load(npz) as f:
            arrays = [np.asarray(f[k], dtype=float) for k in WARM_ARRAYS]
            n, degree = int(f["n_intervals"]), int(f["degree"])
    except (OSError, ValueError, KeyError, TypeError, zipfile.BadZipFile) as exc:
        raise _Damage(npz, f"unreadable ({type(exc).__name__}: {exc})") from None
    if any(a.ndim != 1 or not np.all(np.isfinite(a)) for a in arrays) or n < 1 or degree < 1:
        raise _Damage(npz, "its arrays are not finite vectors of a mesh")
    return Solution(*arrays, n, degree)


def store_solve(store: Path, key: str, rec: dict, warm: Any) -> None:
    """Store a finished solve: the warm start first (a record without it is still usable),
    then the record with its ``"store"`` block (format, key, content hash, the
    ``.npz``'s size and hash), each written whole."""
    store = Path(store)
    store.mkdir(parents=True, exist_ok=True)
    npz_record = None
    if warm is not None:
        with atomic_path(store / f"{key}.npz") as tmp:
            with open(tmp, "wb") as fh:
                np.savez(fh, w=warm.w, lam_x=warm.lam_x, lam_g=warm.lam_g,
                         n_intervals=warm.n_intervals, degree=warm.degree)
            npz_record = {"bytes": tmp.stat().st_size, "sha256": file_sha256(tmp)}
    rec = json.loads(dumps_json(rec, non_finite="nan"))  # the record as it is read back
    block = {"format": FILE_FORMAT, "key": key, "record_sha256": record_sha256(rec),
             "npz": npz_record}
    write_json(store / f"{key}.json", {**rec, "store": block}, indent=1, non_finite="nan")
