"""A cycle-run session on the synthetic bench: its files and its truth.

``bench synth CAMPAIGN --cycle-run profile.csv`` flies the profile on the campaign's true
drive (:mod:`bench.synth.cycle_run`) and logs it as a timeseries session does: the DAQ
(speed, torque at 50 Hz, in the profile's bench frame, with the flange's zero offset,
noise and resolution) and the power analyzer on its own clock (offset, drift, each record
the mean over its interval through a first-order lag, noise, resolution). Each run draws
the instruments' calibration errors within the limits of error ``session.toml`` states
(:class:`Accuracy`), so the stated uncertainty has a truth to cover. ``cycle_truth.json``
beside the files holds the true energy of every cycle.
"""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

import numpy as np
from scipy import signal

from bench.cycle_profile import DriveProfile, read_profile
from bench.synth import instruments as ins
from bench.synth.cycle_run import (
    DEFAULT_CYCLE_BENCH,
    CycleBench,
    RunSignals,
    cycle_truth,
    run_signals,
)
from bench.synth.loss_model import LossModel
from bench.synth.plan import SessionSpec
from bench.synth.session_files import analyzer_preamble
from bench.synth.writers import CsvStream, toml_document
from kernel.errors import InputError
from kernel.files import file_sha256, read_json, write_text_atomic

TRUTH_FILE = "cycle_truth.json"
PROFILE_FILE = "profile.csv"
#: the sensors' full scales at the drum (the shipped campaign's), carried to the bench frame
RANGES_DRUM = {"speed_range_rpm": 3000.0, "torque_range_nm": 100.0, "power_range_w": 15000.0}


@dataclasses.dataclass(frozen=True)
class Accuracy:
    """Limits of error of the instruments, as ``session.toml`` ``[sensors]`` states them.

    Parameters
    ----------
    power_reading : float
        Power analyzer: share of the reading [-] (a WT1800-class analyzer: 0.05 %; 0.1 %
        here, with the current sensors).
    power_range : float
        Power analyzer: share of the power range [-].
    torque_range : float
        Torque flange: accuracy class, share of its range [-] (class 0.1).
    speed_reading : float
        Speed encoder: share of the reading [-].
    """

    power_reading: float = 0.001
    power_range: float = 0.0005
    torque_range: float = 0.001
    speed_reading: float = 0.0001

    def sensor_keys(self) -> dict[str, float]:
        """The ``[sensors]`` keys of these limits."""
        return {f"{k.split('_')[0]}_accuracy_{k.split('_')[1]}": v
                for k, v in dataclasses.asdict(self).items()}


DEFAULT_ACCURACY = Accuracy()


@dataclasses.dataclass(frozen=True)
class CycleRunSpec:
    """The session around the run: id, clocks, instruments, seed."""

    session_id: str = "cycle_01"
    date: str = "2013-05-02"
    daq_start_time: str = "10:00:00.000"
    analyzer_delay_s: float = 0.9
    analyzer_clock_error_s: float = 1.1
    analyzer_drift_ppm: float = 35.0
    seed: int = 20130502
    bench: CycleBench = DEFAULT_CYCLE_BENCH
    accuracy: Accuracy = DEFAULT_ACCURACY
    inst: ins.Instruments = ins.DEFAULT_INSTRUMENTS

    def session_spec(self, profile: DriveProfile) -> SessionSpec:
        """The campaign's session description of this run (for the analyzer's header)."""
        f = profile.frame
        return SessionSpec(self.session_id, "cycle_run", "cycle", 0, 0, 0.0, "csv_en", "en_w",
                           f.measured_side, f.speed_sign, f.torque_sign, "J. Doe", self.date,
                           self.daq_start_time, self.analyzer_delay_s,
                           self.analyzer_clock_error_s, self.analyzer_drift_ppm,
                           self.bench.theta_start_c, self.bench.ambient_c,
                           f"flies {profile.header['scenario']} from a drive profile")


def _errors(rng: np.random.Generator, acc: Accuracy) -> dict[str, float]:
    """This run's calibration errors, uniform within the limits of error."""
    return {"power_gain": float(rng.uniform(-1, 1) * acc.power_reading),
            "power_offset_w": float(rng.uniform(-1, 1) * acc.power_range
                                    * RANGES_DRUM["power_range_w"]),
            "torque_gain": float(rng.uniform(-1, 1) * acc.torque_range),
            "speed_gain": float(rng.uniform(-1, 1) * acc.speed_reading)}


def _write_daq(path: Path, sig: RunSignals, profile: DriveProfile, run: CycleRunSpec,
               err: dict, rng: np.random.Generator) -> int:
    inst = run.inst
    time = np.arange(int(np.floor(sig.time_s[-1] * inst.daq_rate_hz)) + 1) / inst.daq_rate_hz
    speed, torque = profile.frame.to_bench(sig.at("speed_rpm", time), sig.at("torque_nm", time))
    sd = inst.speed_noise_rpm + inst.speed_noise_rel * np.abs(speed)
    speed = speed * (1 + err["speed_gain"]) + sd * rng.standard_normal(time.size)
    torque = (torque * (1 + err["torque_gain"]) + inst.torque_zero_offset_nm
              + inst.torque_noise_nm * rng.standard_normal(time.size))
    writer = CsvStream(path, "Time [s],Speed [rpm],Torque [N m]\n",
                       (3, inst.speed_decimals, inst.torque_decimals))
    writer.write([time, np.round(speed, inst.speed_decimals),
                  np.round(torque, inst.torque_decimals)])
    writer.close(True)
    return int(time.size)


def _write_analyzer(path: Path, sig: RunSignals, profile: DriveProfile, run: CycleRunSpec,
                    err: dict, rng: np.random.Generator) -> tuple[int, float]:
    """Each record: the mean true power over the interval before its time stamp (its own
    clock), a first-order lag, the calibration error, noise, resolution."""
    inst = run.inst
    preamble, header_offset = analyzer_preamble(run.session_spec(profile), 0, inst)
    rate = 1.0 + run.analyzer_drift_ppm * 1e-6
    dt = inst.analyzer_interval_s
    n = int(np.floor((sig.time_s[-1] - run.analyzer_delay_s) / (dt * rate)))
    t_own = np.arange(1, n + 1) * dt
    t_true = run.analyzer_delay_s + t_own * rate
    energy = np.concatenate([[0.0], np.cumsum(0.5 * (sig.p_elec_w[1:] + sig.p_elec_w[:-1])
                                              * np.diff(sig.time_s))])
    mean = (np.interp(t_true, sig.time_s, energy)
            - np.interp(t_true - dt * rate, sig.time_s, energy)) / (dt * rate)
    a = np.exp(-dt / inst.analyzer_tau_s)
    lagged, _ = signal.lfilter([1 - a], [1, -a], mean, zi=[a * mean[0]])
    p = lagged * (1 + err["power_gain"]) + err["power_offset_w"]
    p = p + (inst.power_noise_w + inst.power_noise_rel * np.abs(p)) * rng.standard_normal(n)
    p = np.round(p / inst.power_lsb_w) * inst.power_lsb_w
    u = inst.grid_voltage_v + 0.05 * rng.standard_normal(n)
    s = np.hypot(p, inst.reactive_power_var + 0.03 * np.abs(p))
    writer = CsvStream(path, preamble, (0, 3, 2, 3, 0, 4))
    writer.write([np.arange(1, n + 1), t_own, u, s / (np.sqrt(3.0) * u), p, p / s])
    writer.close(True)
    return n, header_offset


def _session_toml(profile: DriveProfile, run: CycleRunSpec) -> str:
    f = profile.frame
    gear = f.gear_ratio if f.measured_side == "motor" else 1.0
    sensors = {"speed_range_rpm": RANGES_DRUM["speed_range_rpm"] * gear,
               "torque_range_nm": RANGES_DRUM["torque_range_nm"] / gear,
               "power_range_w": RANGES_DRUM["power_range_w"], **run.accuracy.sensor_keys()}
    top = {"session_id": run.session_id, "kind": "cycle_run", "mode": "cycle",
           "operator": "J. Doe", "date": run.date, **f.keys(),
           "notes": f"the drive profile of {profile.header['scenario']} flown on the bench"}
    return toml_document(top, {
        "daq": {"file": "daq.csv", "format": "csv",
                "start": f"{run.date}T{run.daq_start_time}"},
        "analyzer": {"file": "analyzer.csv", "format": "vendor_csv"},
        "cycle": {"profile": PROFILE_FILE}, "sensors": sensors})


def campaign_loss_model(truth_path: Path) -> LossModel:
    """The true loss model of a synthetic campaign (its ``truth.json``)."""
    truth = read_json(truth_path, what="synthetic campaign truth")
    try:
        return LossModel.from_dict(truth["loss_model"])
    except (KeyError, TypeError) as exc:
        raise InputError(truth_path, f"no loss model ({exc})", column="loss_model",
                         expected="the truth.json bench synth writes") from exc


def write_cycle_run(campaign: str | Path, profile_path: str | Path,
                    run: CycleRunSpec = CycleRunSpec(), *,
                    truth_path: str | Path | None = None) -> dict:
    """Fly ``profile_path`` on the synthetic bench into ``campaign/<session_id>/``.

    Parameters
    ----------
    campaign : path
        The campaign folder the session goes into.
    profile_path : path
        The drive profile (``bench cycle export``), copied into the session folder.
    run : CycleRunSpec
        Session id, clocks, bench, instruments, seed.
    truth_path : path, optional
        The campaign truth whose loss model is the drive's (default
        ``campaign/truth.json``).

    Returns
    -------
    dict
        The truth written to ``cycle_truth.json``.
    """
    campaign, profile_path = Path(campaign), Path(profile_path)
    truth_path = Path(truth_path) if truth_path is not None else campaign / "truth.json"
    model = campaign_loss_model(truth_path)
    profile = read_profile(profile_path)
    folder = campaign / run.session_id
    folder.mkdir(parents=True, exist_ok=True)
    (folder / TRUTH_FILE).unlink(missing_ok=True)  # incomplete until the truth is back
    streams = [np.random.default_rng(s) for s in np.random.SeedSequence(run.seed).spawn(3)]
    err = _errors(streams[0], run.accuracy)
    sig = run_signals(profile, model, run.bench)
    daq_rows = _write_daq(folder / "daq.csv", sig, profile, run, err, streams[1])
    an_rows, header_offset = _write_analyzer(folder / "analyzer.csv", sig, profile, run, err,
                                             streams[2])
    if profile_path.resolve() != (folder / PROFILE_FILE).resolve():
        shutil.copyfile(profile_path, folder / PROFILE_FILE)
    write_text_atomic(folder / "session.toml", _session_toml(profile, run))
    truth = {
        "schema": "drivebench.synth_cycle_truth", "seed": run.seed,
        "scenario": profile.header["scenario"],
        "profile_sha256": file_sha256(folder / PROFILE_FILE),
        "campaign_truth": str(truth_path),
        "sign_convention": "drum frame; p_elec_w > 0 drawn from the grid",
        "bench": dataclasses.asdict(run.bench), "accuracy": dataclasses.asdict(run.accuracy),
        "calibration_errors": err,
        "clock": {"model": "t_daq_s = offset_s + (1 + drift_ppm * 1e-6) * t_analyzer_s",
                  "offset_s": run.analyzer_delay_s, "drift_ppm": run.analyzer_drift_ppm,
                  "header_offset_s": header_offset},
        "profile_start_daq_s": run.bench.lead_s, "daq_rows": daq_rows,
        "analyzer_rows": an_rows, "cycles": cycle_truth(sig, profile, run.bench),
    }
    write_text_atomic(folder / TRUTH_FILE, json.dumps(truth, indent=1) + "\n")
    return truth
