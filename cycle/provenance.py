"""The cycle verified is the cycle flown: the profile's provenance checked against the sweep.

``bench cycle export`` writes into the profile's header the sweep's run id, the scenario,
the power model's hash and the hash of the scenario's trajectory (:func:`trajectory_sha256`);
``bench ingest`` keeps them with the cycle-run session, beside the profile's own
mechanical energy per cycle integrated from its set-points; ``bench cycle verify`` compares
the session with a sweep only when all of them are the sweep's (:func:`check_provenance`).
"""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
import pandas as pd

from bench.cycle_profile import E_MECH_RTOL, PROVENANCE_KEYS
from kernel.errors import InputError

#: the trajectory columns the export interpolates: what the hash binds
HASHED_COLUMNS = ("time_s", "speed_rpm", "torque_nm", "p_elec_w")


def trajectory_sha256(points: pd.DataFrame) -> str:
    """SHA-256 of one scenario's collocation points (sorted by time): the float64 bytes
    of :data:`HASHED_COLUMNS`, row by row."""
    rows = points.sort_values("time_s")[list(HASHED_COLUMNS)].to_numpy(np.float64)
    return hashlib.sha256(np.ascontiguousarray(rows).tobytes()).hexdigest()


def sweep_ids(manifest: dict) -> dict[str, str]:
    """The sweep's run id and its power model's hash (``""`` when it states none)."""
    return {"optimize_run_id": str((manifest.get("provenance") or {}).get("run_id", "")),
            "power_model_sha256": str((manifest.get("drive_model") or {})
                                      .get("model_sha256", ""))}


def _short(value: str) -> str:
    return f"{value[:12]}..." if len(value) > 15 else value or "none"


def _refuse(where: Path, key: str, problem: str, expected: str) -> InputError:
    return InputError(where, problem, column=key, expected=expected)


def check_provenance(info: dict, sid: str, optimize: Path, manifest: dict,
                     trajectories: pd.DataFrame, e_mech_j: float, model_sha256: str) -> None:
    """Raise InputError unless the session's profile came from this sweep's scenario.

    Parameters
    ----------
    info : dict
        The session's ``cycles`` entry of the store manifest (``scenario``,
        ``provenance``: :data:`PROVENANCE_KEYS`, ``e_mech_profile_j``, ``profile``).
    sid : str
        The session id, for the messages.
    optimize : Path
        The optimize folder.
    manifest : dict
        Its ``manifest.json``.
    trajectories : pandas.DataFrame
        Its ``trajectories.parquet``.
    e_mech_j : float
        The scenario's mechanical energy per cycle (``summary.parquet``) [J].
    model_sha256 : str
        The hash of the power model the predictions would use.

    Raises
    ------
    InputError
        Naming both ids: the session was ingested without the profile's provenance, the
        sweep is another run, its power model (or the one given) is another, the
        scenario's trajectory is not the one exported (a relabelled profile), or the
        profile's set-points integrate to another mechanical energy than the scenario's.
    """
    prov, scenario = info.get("provenance") or {}, info["scenario"]
    profile = f"profile {info.get('profile', '?')} (session {sid!r})"
    redo = "a profile of this sweep (bench cycle export), flown and ingested"
    if not all(prov.get(k) for k in PROVENANCE_KEYS) or "e_mech_profile_j" not in info:
        missing = next((k for k in PROVENANCE_KEYS if not prov.get(k)), "e_mech_profile_j")
        raise _refuse(optimize, "--session", f"{profile} states no {missing}: which sweep "
                      "and cycle it flew cannot be checked", f"{redo}, or the session "
                      "ingested again by this version")
    ids = sweep_ids(manifest)
    for key, mine in ids.items():
        if prov[key] != mine:
            what = "run" if key == "optimize_run_id" else "power model"
            raise _refuse(optimize / "manifest.json", key, f"the sweep is {what} "
                          f"{_short(mine)}, {profile} was exported from {what} "
                          f"{_short(prov[key])}", f"the optimize folder the profile was "
                          f"exported from ({key} {prov[key]})")
    if model_sha256 != prov["power_model_sha256"]:
        raise _refuse(optimize / "manifest.json", "power_model_sha256", f"the power model "
                      f"given is {_short(model_sha256)}, {profile} was exported with "
                      f"{_short(prov['power_model_sha256'])}", "the sweep's power model")
    _check_trajectory(prov["trajectory_sha256"], scenario, trajectories, optimize, profile)
    body = float(info["e_mech_profile_j"])
    if not abs(body - e_mech_j) <= E_MECH_RTOL * abs(e_mech_j):
        raise _refuse(optimize / "summary.parquet", "e_mech_j", f"the set-points of {profile} "
                      f"integrate to {body:.1f} J of mechanical energy per cycle, scenario "
                      f"{scenario!r} to {e_mech_j:.1f} J: the profile flew another cycle "
                      "than its header names", f"{redo} (within {100 * E_MECH_RTOL:g} %)")


def _check_trajectory(want: str, scenario: str, trajectories: pd.DataFrame, optimize: Path,
                      profile: str) -> None:
    """Raise InputError unless ``scenario``'s trajectory hashes to ``want``, naming the
    scenario that does."""
    hashes = {str(s): trajectory_sha256(g) for s, g in trajectories.groupby("scenario")}
    if hashes.get(scenario) == want:
        return
    match = [s for s, h in hashes.items() if h == want]
    flown = f"that of scenario {match[0]!r}" if match else "no scenario's of this sweep"
    raise _refuse(optimize / "trajectories.parquet", "trajectory_sha256",
                  f"{profile} names scenario {scenario!r} (trajectory "
                  f"{_short(hashes.get(scenario, ''))}) but its trajectory_sha256 "
                  f"{_short(want)} is {flown}: a relabelled profile",
                  f"the profile as exported for {scenario!r}")
