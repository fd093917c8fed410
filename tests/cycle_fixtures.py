"""An optimize folder with analytic cycles, written by the sweep's own writer, for the
cycle round-trip tests (``bench cycle export`` and what follows it).

Speed and torque are one harmonic each, so the mechanical energy per cycle has a closed
form: ``E = (pi / 30) T (a A + b B / 2)`` for ``n = a + b cos(2 pi t / T)`` [rpm] and
``tau = A + B cos(2 pi t / T)`` [N m].
"""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np
import pandas as pd

from kernel.provenance import Provenance
from kernel.units import RPM_PER_RAD_S
from optimize.paper_model import paper_model
from optimize.sweep_folder import write_sweep_folder

#: scenario -> (period [s], a, b [rpm], A, B [N m]); the second leaves the 1500 rpm limit
CYCLES = {"elec-lim-7.0": (6.0, -300.0, -900.0, 40.0, 30.0),
          "elec-lim-5.5": (7.0, -200.0, -700.0, 35.0, 25.0),
          "elec-free-9.0": (5.0, -400.0, -1300.0, 45.0, 30.0)}
LIMITS = {"nominal_power_w": 8200.0, "max_speed_rpm": 1500.0, "max_torque_nm": 78.0}


def exact_e_mech_j(scenario: str) -> float:
    """The closed-form mechanical energy per cycle of a fixture scenario [J]."""
    period, a, b, big_a, big_b = CYCLES[scenario]
    return math.pi / 30.0 * period * (a * big_a + b * big_b / 2.0)


def _cycle(scenario: str, model, n: int = 160) -> tuple[dict, pd.DataFrame]:
    period, a, b, big_a, big_b = CYCLES[scenario]
    t = np.arange(1, n + 1) * period / n  # (0, T], as the Radau points
    c = np.cos(2 * np.pi * t / period)
    speed, torque = a + b * c, big_a + big_b * c
    p_elec, p_mech = model.p_elec_w(speed, torque), speed * torque / RPM_PER_RAD_S
    w = np.full(n, 1.0 / n)
    kind, wind = scenario.rsplit("-", 1)
    row = {"scenario": scenario, "kind": kind, "objective": "electrical",
           "drive_limits": kind.endswith("lim"), "wind_speed_m_s": float(wind),
           "success": True, "status": "Solve_Succeeded", "result_check": "passed",
           "period_s": period, "avg_p_elec_w": float(w @ p_elec),
           "avg_p_mech_w": float(w @ p_mech), "e_elec_j": float(w @ p_elec) * period,
           "e_mech_j": float(w @ p_mech) * period,
           "peak_speed_rpm": float(np.abs(speed).max()), "peak_torque_nm": float(torque.max())}
    traj = pd.DataFrame({"scenario": scenario, "kind": kind,
                         "wind_speed_m_s": row["wind_speed_m_s"], "time_s": t, "weight": w,
                         "l_m": 100.0 + 0 * t, "speed_rpm": speed, "torque_nm": torque,
                         "p_elec_w": p_elec, "p_mech_w": p_mech})
    return row, traj


def write_cycle_sweep(folder, edit=None) -> object:
    """Write the fixture optimize folder; returns the power model it flew with (the
    paper's, carried into the folder). ``edit(trajectories)``, when given, changes the
    trajectories in place before they are written (a hostile sweep)."""
    model = paper_model()
    rows, trajs = zip(*(_cycle(s, model) for s in CYCLES), strict=True)
    trajectories = pd.concat(trajs, ignore_index=True)
    if edit is not None:
        edit(trajectories)
    manifest = {"wind_speeds_m_s": [5.5, 7.0, 9.0], "kinds": ["elec-lim", "elec-free"],
                "scenarios": list(CYCLES),
                "drive_model": {"path": "", "file_sha256": "", "model_sha256": model.sha256,
                                "name": model.name, "note": "analytic test cycles"},
                "sections": {"drive": dict(LIMITS)}}
    write_sweep_folder(folder, Provenance.start(("tests",)), summary=pd.DataFrame(rows),
                       trajectories=trajectories, manifest=manifest,
                       system=None, carried_model=model)
    return model


def copy_session(base: Path, tmp_path: Path, name: str, edit=None) -> tuple[Path, Path]:
    """A copy of ``base``'s store, and a campaign holding a copy of its session
    ``cycle_s1`` under the id ``name``, its profile changed by ``edit(text)`` when given:
    ``(store, campaign)``."""
    store = tmp_path / "store"
    shutil.copytree(base / "store", store)
    camp = tmp_path / "campaign"
    shutil.copytree(base / "campaign" / "cycle_s1", camp / name)
    shutil.copy(base / "campaign" / "drive.toml", camp)
    toml = camp / name / "session.toml"
    toml.write_text(toml.read_text().replace('"cycle_s1"', f'"{name}"'))
    if edit is not None:
        profile = camp / name / "profile.csv"
        profile.write_text(edit(profile.read_text()))
    return store, camp
