"""``bench cycle export``: one converged scenario of an optimize folder as a drive profile.

The cycle's collocation points (``trajectories.parquet``, docs/schemas.md §5) are
interpolated periodically with monotone cubic pieces (PCHIP: no overshoot, so a cycle
on its torque limit stays on it), sampled at the bench's rate, preceded by a standstill
(the torque flange's tare) and a ramp from standstill to the cycle's start, repeated for
N cycles and followed by a ramp back. The ramps are raised cosines no steeper than the
cycle itself. A cycle outside the bench's rating (the sweep's drive limits, the bench
session's drive rating and stated sensor ranges) is refused, naming the time and value.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.interpolate import PchipInterpolator

from bench.cycle_profile import (
    SIGN_CONVENTION,
    BenchFrame,
    DriveProfile,
    check_tables_replaceable,
    cycle_integrals,
    is_profile,
    write_profile,
)
from bench.ingest.session import load_session
from cycle.provenance import HASHED_COLUMNS, sweep_ids, trajectory_sha256
from kernel.drive import BOX_KEYS, Drive
from kernel.drive_file import find_drive_file, session_drive
from kernel.errors import InputError
from kernel.output_folder import output_file
from kernel.provenance import Provenance
from kernel.units import RPM_PER_RAD_S
from optimize.sweep_folder import read_sweep_folder, read_trajectories, sweep_drive

#: a set-point may exceed a limit by this share (an optimum sits on its bound to the
#: solver's tolerance)
LIMIT_RTOL = 1e-3
#: standstill after the ramp out [s]
TAIL_S = 2.0
#: points wrapped around each end of the cycle for the periodic interpolation
WRAP = 8


#: the command-line option of each of :class:`ExportOptions`' fields, and its range
OPTIONS = {"n_cycles": "--cycles", "rate_hz": "--rate-hz", "standstill_s": "--standstill-s",
           "ramp_s": "--ramp-s"}
LIMITS = {"n_cycles": "a whole number >= 1", "rate_hz": "1 Hz to 100 kHz",
          "standstill_s": ">= 2 s (the tare)", "ramp_s": "> 0 s"}


@dataclass(frozen=True)
class ExportOptions:
    """How the cycle is laid out for the bench.

    Parameters
    ----------
    n_cycles : int
        Cycles in a row.
    rate_hz : float
        The bench controller's set-point rate [Hz].
    standstill_s : float
        Standstill before the ramp in, for the torque flange's tare [s].
    ramp_s : float
        Shortest ramp from standstill to the cycle's start and back [s]; longer when
        the cycle's own largest rate of speed or torque would be exceeded.
    frame : BenchFrame
        The bench's frame (shaft side, gear ratio, signs) of the set-points.
    """

    n_cycles: int = 10
    rate_hz: float = 100.0
    standstill_s: float = 10.0
    ramp_s: float = 3.0
    frame: BenchFrame = field(default_factory=BenchFrame)

    def __post_init__(self) -> None:
        checks = {"n_cycles": self.n_cycles >= 1, "rate_hz": 1.0 <= self.rate_hz <= 100_000,
                  "standstill_s": self.standstill_s >= 2.0, "ramp_s": self.ramp_s > 0}
        for name, ok in checks.items():
            value = getattr(self, name)
            if not ok or not math.isfinite(value) or (name == "n_cycles"
                                                     and value != int(value)):
                raise InputError(None, f"{OPTIONS[name]} {value!r}: not {LIMITS[name]}",
                                 expected=f"{OPTIONS[name]} {LIMITS[name]}")


DEFAULT_EXPORT = ExportOptions()


@dataclass(frozen=True)
class Limit:
    """One limit a set-point must keep: drum-frame quantity, value, where it comes from."""

    quantity: str  # "speed" [rpm, |value|] or "torque" [N m, |value|]
    value: float
    source: str


def scenario_cycle(folder: Path, scenario: str) -> tuple[pd.Series, pd.DataFrame, dict]:
    """The summary row, the collocation points (sorted by time) and the manifest of one
    converged scenario of an optimize folder.

    Raises
    ------
    InputError
        The folder is not a whole optimize output, or the scenario is absent or failed.
    """
    summary, manifest = read_sweep_folder(folder)
    ok = summary[summary["success"].astype(bool)]
    row = summary[summary["scenario"] == scenario]
    if row.empty or not bool(row.iloc[0]["success"]):
        why = "not in the sweep" if row.empty else f"failed ({row.iloc[0]['status']})"
        raise InputError(folder / "summary.parquet", f"scenario {scenario!r} {why}",
                         column="--scenario", expected="a converged scenario: "
                         + ", ".join(ok["scenario"].astype(str)))
    traj = read_trajectories(folder)
    points = traj[traj["scenario"] == scenario].sort_values("time_s")
    if len(points) < 4:
        raise InputError(folder / "trajectories.parquet", f"no cycle of {scenario!r}",
                         expected="its collocation points")
    values = points[list(HASHED_COLUMNS)].to_numpy(float)
    if not np.isfinite(values).all():
        bad = HASHED_COLUMNS[int(np.flatnonzero(~np.isfinite(values).all(axis=0))[0])]
        raise InputError(folder / "trajectories.parquet", f"scenario {scenario!r} has a "
                         f"non-finite {bad}", column=bad, expected="the finite collocation "
                         "points of a converged cycle (run bench optimize again)")
    period = float(row.iloc[0]["period_s"])
    if not (math.isfinite(period) and period > 0):
        raise InputError(folder / "summary.parquet", f"scenario {scenario!r}: period_s "
                         f"{period!r}", column="period_s", expected="the cycle's period, "
                         "a finite number > 0 [s]")
    return row.iloc[0], points, manifest


def periodic_interpolants(points: pd.DataFrame, period_s: float) -> dict[str, PchipInterpolator]:
    """PCHIP interpolants of speed [rpm], torque [N m] and p_elec [W] over cycle time,
    continued periodically by wrapping :data:`WRAP` points around each end."""
    t = points["time_s"].to_numpy(float)
    x = np.concatenate([t[-WRAP:] - period_s, t, t[:WRAP] + period_s])
    out = {}
    for name in ("speed_rpm", "torque_nm", "p_elec_w"):
        y = points[name].to_numpy(float)
        out[name] = PchipInterpolator(x, np.concatenate([y[-WRAP:], y, y[:WRAP]]))
    return out


def flown_drive(manifest: dict, folder: Path) -> Drive:
    """The ``[drive]`` in force the sweep in ``folder`` flew (its manifest's
    ``sections.drive``, :func:`optimize.sweep_folder.sweep_drive`).

    Raises
    ------
    InputError
        A manifest that records none (an older ``bench optimize``'s: its limits unknown
        here, no cycle is exported unchecked), or one that is not a drive.
    """
    drive = sweep_drive(manifest, folder)
    if drive is None:
        raise InputError(Path(folder) / "manifest.json", "no record of the drive the sweep "
                         "flew (sections.drive): a folder of an older bench optimize",
                         column="sections", expected="re-run `bench optimize` with this "
                                                     "version")
    return drive


def bench_limits(rating: Drive, session_dir: Path | None) -> list[Limit]:
    """The limits of the sweep's drive (``rating``, its ``[drive]`` in force,
    :func:`flown_drive`) and, given a bench session folder, of its drive rating
    (``drive.toml``, ``session.toml``) and its stated sensor ranges (drum frame)."""
    limits = []
    for q, key, value in zip(("speed", "torque"), BOX_KEYS, rating.box(), strict=True):
        if value:
            limits.append(Limit(q, float(value), f"the sweep's drive limits ({key})"))
    if session_dir is None:
        return limits
    s = load_session(session_dir)
    drive_file = find_drive_file(s.folder, [s.folder.parent])
    drive = session_drive(s.raw, s.path, drive_file, str(drive_file)) or {}
    for q, key in zip(("speed", "torque"), BOX_KEYS, strict=True):
        if drive.get(key):
            limits.append(Limit(q, float(drive[key]), f"{drive['sources'][key]} {key}"))
    gear = s.gear_ratio if s.measured_side == "motor" else 1.0
    sensors = s.raw.get("sensors", {})
    for q, key, to_drum in (("speed", "speed_range_rpm", 1 / gear),
                            ("torque", "torque_range_nm", gear)):
        if sensors.get(key):
            limits.append(Limit(q, float(sensors[key]) * to_drum,
                                f"{s.path} [sensors] {key} (at the drum)"))
    return limits


def check_limits(phase_s: np.ndarray, speed: np.ndarray, torque: np.ndarray,
                 limits: list[Limit], scenario: str, where: Path) -> None:
    """Raise InputError at the first set-point beyond a limit, naming time, value, limit."""
    values = {"speed": np.abs(speed), "torque": np.abs(torque)}
    for lim in limits:
        over = values[lim.quantity] > lim.value * (1 + LIMIT_RTOL)
        if over.any():
            i = int(np.argmax(values[lim.quantity]))
            unit = "rpm" if lim.quantity == "speed" else "N m"
            raise InputError(where, f"scenario {scenario!r} leaves the bench's rating: "
                             f"|{lim.quantity}| {values[lim.quantity][i]:.1f} {unit} at "
                             f"t = {phase_s[i]:.3f} s of the cycle (first at "
                             f"{phase_s[np.argmax(over)]:.3f} s), above {lim.value:g} {unit} "
                             f"({lim.source})", column="--scenario",
                             expected="a cycle within the bench's speed and torque limits "
                             "(a *-lim scenario)")


def _ramp(n: int, start: float, end: float) -> np.ndarray:
    """``n`` samples of a raised cosine from ``start`` to ``end`` (both ends excluded)."""
    s = (np.arange(1, n + 1) / (n + 1))
    return start + (end - start) * 0.5 * (1 - np.cos(np.pi * s))


def _ramp_samples(opts: ExportOptions, f: dict, period_s: float) -> int:
    """Samples of a ramp: at least ``ramp_s``, and no steeper than the cycle's own
    largest rate of speed and torque (a raised cosine's peak rate is pi/2 x mean)."""
    phase = np.arange(0.0, period_s, 1.0 / opts.rate_hz)
    need = opts.ramp_s
    for name in ("speed_rpm", "torque_nm"):
        rate = np.abs(f[name].derivative()(phase)).max()
        if rate > 0:
            need = max(need, math.pi / 2 * abs(float(f[name](0.0))) / rate)
    return int(math.ceil(need * opts.rate_hz))


def build_columns(f: dict, period_s: float, opts: ExportOptions,
                  model_p_elec) -> tuple[dict, float]:
    """The profile's drum-frame columns and the time of cycle 0's start [s]."""
    dt = 1.0 / opts.rate_hz
    n_still = int(round(opts.standstill_s * opts.rate_hz))
    n_ramp = _ramp_samples(opts, f, period_s)
    t_start = (n_still + n_ramp) * dt
    n_cyc = int(math.ceil(opts.n_cycles * period_s * opts.rate_hz))
    t_cyc = t_start + np.arange(n_cyc) * dt
    phase = np.mod(t_cyc - t_start, period_s)
    cyc_speed, cyc_torque = f["speed_rpm"](phase), f["torque_nm"](phase)
    # the last cycle ends where every cycle starts (the interpolants are periodic)
    end_speed, end_torque = (float(f[k](0.0)) for k in ("speed_rpm", "torque_nm"))
    n_tail = int(round(TAIL_S * opts.rate_hz))
    speed = np.concatenate([np.zeros(n_still), _ramp(n_ramp, 0.0, float(f["speed_rpm"](0.0))),
                            cyc_speed, _ramp(n_ramp, end_speed, 0.0), np.zeros(n_tail)])
    torque = np.concatenate([np.zeros(n_still), _ramp(n_ramp, 0.0, float(f["torque_nm"](0.0))),
                             cyc_torque, _ramp(n_ramp, end_torque, 0.0), np.zeros(n_tail)])
    time = np.arange(speed.size) * dt
    cycle = np.full(speed.size, -1, np.int64)
    cycle[n_still + n_ramp:n_still + n_ramp + n_cyc] = np.floor(
        (t_cyc - t_start) / period_s).astype(np.int64)
    p_elec = np.asarray(model_p_elec(speed, torque), float)
    in_cycle = cycle >= 0
    p_elec[in_cycle] = f["p_elec_w"](phase)  # the optimizer's own prediction in the cycles
    return {"time_s": time, "speed_rpm": speed, "torque_nm": torque, "p_elec_w": p_elec,
            "p_mech_w": speed * torque / RPM_PER_RAD_S, "cycle": cycle}, t_start


@dataclass(frozen=True)
class Exported:
    """What :func:`export_cycle` wrote.

    Attributes
    ----------
    files : dict of Path
        ``profile``, ``speed``, ``torque``.
    profile : DriveProfile
        The profile as written.
    e_mech_cycles_j : numpy.ndarray
        The profile's integral of speed x torque over each cycle [J].
    """

    files: dict
    profile: DriveProfile
    e_mech_cycles_j: np.ndarray

    @property
    def e_mech_error(self) -> float:
        """Largest relative difference of a cycle's mechanical energy from the
        optimizer's [-]."""
        pred = float(self.profile.header["e_mech_pred_j"])
        return float(np.max(np.abs(self.e_mech_cycles_j / pred - 1.0)))


def export_cycle(folder: str | Path, scenario: str, out: str | Path,
                 options: ExportOptions = DEFAULT_EXPORT, *,
                 bench_session: str | Path | None = None, model=None,
                 command_line=("drivebench.cycle_export",)) -> Exported:
    """Write ``scenario`` of the optimize ``folder`` as a drive profile ``out``.

    Parameters
    ----------
    folder : path
        An optimize output folder (docs/schemas.md §5).
    scenario : str
        A converged scenario of it, e.g. ``"elec-lim-7.0"``.
    out : path
        The profile CSV (new, or an earlier profile); its two plain tables go beside it.
    options : ExportOptions
        Cycles, rate, standstill, ramp, the bench frame.
    bench_session : path, optional
        A session folder of the bench's campaign: its drive rating and stated sensor
        ranges are limits too.
    model : PowerModel, optional
        The power model for the standstill and ramps' predicted p_elec; default the one
        the sweep flew with (its manifest's ``drive_model.path``).
    command_line : sequence of str
        Recorded in the header's provenance.
    """
    from cycle.models import sweep_power_model

    folder, out = Path(folder), Path(out)
    # before the work, under the profile's lock: another export in mid-write (its tables
    # written, the profile naming them not yet) is waited for, not taken for a user's files
    with output_file(out, "cycle export", is_profile):
        check_tables_replaceable(out)
    provenance = Provenance.start(command_line)
    row, points, manifest = scenario_cycle(folder, scenario)
    drive = flown_drive(manifest, folder)
    period = float(row["period_s"])
    f = periodic_interpolants(points, period)
    phase = np.concatenate([points["time_s"].to_numpy(float),
                            np.arange(0.0, period, 1.0 / options.rate_hz)])
    check_limits(phase, f["speed_rpm"](phase), f["torque_nm"](phase),
                 bench_limits(drive, Path(bench_session) if bench_session else None),
                 scenario, folder / "trajectories.parquet")
    model = model if model is not None else sweep_power_model(folder, manifest)
    cols, t_start = build_columns(f, period, options, model.p_elec_w)
    energies = cycle_integrals(cols["time_s"], cols["p_mech_w"], t_start, period,
                               options.n_cycles)
    speed_b, torque_b = options.frame.to_bench(cols["speed_rpm"], cols["torque_nm"])
    header = _header(row, manifest, drive, folder, options, t_start, energies,
                     bench_session, provenance, trajectory_sha256(points))
    profile = DriveProfile(header, {"time_s": cols["time_s"], "speed_set_rpm": speed_b,
                                    "torque_set_nm": torque_b, "p_elec_pred_w": cols["p_elec_w"],
                                    "p_mech_pred_w": cols["p_mech_w"], "cycle": cols["cycle"]})
    # one export per profile at a time: the three files are checked again and written
    # under the profile's lock (a second export waits, then replaces all three)
    with output_file(out, "cycle export", is_profile):
        check_tables_replaceable(out)
        files = write_profile(out, profile)
    return Exported(files, profile, energies)


def _header(row, manifest: dict, rating: Drive, folder: Path, opts: ExportOptions,
             t_start: float, energies: np.ndarray, bench_session, provenance: Provenance,
             trajectory: str) -> dict:
    return {
        "scenario": str(row["scenario"]), "optimize_folder": str(folder.resolve()),
        **sweep_ids(manifest), "trajectory_sha256": trajectory,
        **opts.frame.keys(),
        "bench_session": str(Path(bench_session).resolve()) if bench_session else "",
        "speed_unit": "rpm", "torque_unit": "N m", "power_unit": "W",
        "sign_convention": SIGN_CONVENTION,
        "rate_hz": float(opts.rate_hz), "period_s": float(row["period_s"]),
        "n_cycles": int(opts.n_cycles), "standstill_s": float(opts.standstill_s),
        "cycle_start_s": round(t_start, 9),
        "e_elec_pred_j": float(row["e_elec_j"]), "e_mech_pred_j": float(row["e_mech_j"]),
        "e_mech_profile_j": float(np.mean(energies)),
        **{key: float(value or 0.0) for key, value in zip(BOX_KEYS, rating.box(),
                                                           strict=True)},
        "provenance": provenance.header(),
    }
