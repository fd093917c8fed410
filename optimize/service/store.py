"""Finished solves stored under the hash of their inputs, so a re-run resumes.

``<key>.json`` holds a solve's record, ``<key>.npz`` its primal and dual vectors
(the next solve's warm start), each written whole (:func:`kernel.files.atomic_write`).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
from pathlib import Path
from typing import Any

import numpy as np

from kernel.files import atomic_write, write_json
from optimize.kinds import KINDS

#: bump when the meaning of a stored solve changes (invalidates every stored solve)
STORE_VERSION = 1


def solve_key(problem: Any, kind: str, wind_speed_m_s: float) -> str:
    """SHA-256 (hex) of everything one solve depends on: the drive model's hash, the OCP
    options, the wind speed, the kind's objective and limits, the system's hash (when
    the problem has a system).

    ``problem`` is an :class:`optimize.service.builder.Problem`.
    """
    k = KINDS[kind]
    data = {"version": STORE_VERSION, "model": problem.drive_model.sha256,
            "options": dataclasses.asdict(problem.options), "wind_speed_m_s": float(wind_speed_m_s),
            "objective": k.objective, "drive_limits": bool(k.drive_limits)}
    if problem.system is not None:
        data["system"] = problem.system.sha256
    text = json.dumps(data, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def load_solve(store: Path, key: str) -> tuple[dict, Any] | None:
    """A stored solve (its record, its warm start or None) or None when absent or unreadable."""
    from optimize.solve.result import Solution

    js, npz = store / f"{key}.json", store / f"{key}.npz"
    if not js.is_file():
        return None
    try:
        rec = json.loads(js.read_text(encoding="utf-8"))
        warm = None
        if npz.is_file():
            with np.load(npz) as f:
                warm = Solution(f["w"], f["lam_x"], f["lam_g"], int(f["n_intervals"]),
                                int(f["degree"]))
    except (OSError, ValueError, KeyError):
        return None
    return rec, warm


def store_solve(store: Path, key: str, rec: dict, warm: Any) -> None:
    """Store a finished solve: the warm start first (a record without it is still usable),
    then the record, each written whole."""
    store.mkdir(parents=True, exist_ok=True)
    if warm is not None:
        def write_npz(tmp: Path) -> None:
            with open(tmp, "wb") as fh:
                np.savez(fh, w=warm.w, lam_x=warm.lam_x, lam_g=warm.lam_g,
                         n_intervals=warm.n_intervals, degree=warm.degree)
        atomic_write(store / f"{key}.npz", write_npz)
    write_json(store / f"{key}.json", rec, indent=1, non_finite="nan")
