"""The true signals of a bench flying a drive profile (a cycle-run session).

The load machine's speed loop and the drive under test's torque loop follow their
set-points as second-order systems of finite bandwidth; the drivetrain's inertia draws
``J omega domega/dt`` from the grid; the drive's true losses are the campaign's
(:mod:`bench.synth.loss_model`: the quadratic and what it misses, friction, iron, gear,
fan, the copper's temperature), with the winding heating over the run. Time is the DAQ
clock; the profile starts ``lead_s`` after the DAQ does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

from bench.cycle_profile import DriveProfile, window_integral
from bench.synth.loss_model import LossModel, loss_w, theta_step, true_p_elec_w
from bench.synth.true_signals import DEFAULT_DYNAMICS
from kernel.units import RPM_PER_RAD_S


@dataclass(frozen=True)
class CycleBench:
    """The bench running a profile.

    Parameters
    ----------
    speed_bandwidth_hz : float
        Natural frequency of the load machine's speed loop [Hz].
    speed_zeta : float
        Its damping ratio [-].
    torque_bandwidth_hz : float
        Natural frequency of the drive under test's torque loop [Hz].
    torque_zeta : float
        Its damping ratio [-].
    inertia_kg_m2 : float
        Rotating inertia reflected to the drum shaft [kg m^2] (the campaign's).
    sim_rate_hz : float
        Rate the true signals are computed at [Hz].
    thermal_step_s : float
        Step of the winding temperature's recurrence [s] (loss held over a step).
    lead_s : float
        DAQ logging before the profile starts [s].
    tail_s : float
        DAQ logging after the profile ends [s].
    theta_start_c : float
        Winding temperature at the start [degC]: a drive warmed up on the bench, within
        the campaign's session temperatures (37 to 71 degC at their starts).
    ambient_c : float
        Bench-room temperature [degC].
    """

    speed_bandwidth_hz: float = 8.0
    speed_zeta: float = 0.8
    torque_bandwidth_hz: float = 25.0
    torque_zeta: float = 0.7
    inertia_kg_m2: float = DEFAULT_DYNAMICS.inertia_kg_m2
    sim_rate_hz: float = 1000.0
    thermal_step_s: float = 0.1
    lead_s: float = 2.0
    tail_s: float = 1.0
    theta_start_c: float = 50.0
    ambient_c: float = 22.0


DEFAULT_CYCLE_BENCH = CycleBench()


@dataclass(frozen=True)
class RunSignals:
    """True drum-frame signals on the simulation grid (DAQ clock)."""

    time_s: np.ndarray
    speed_rpm: np.ndarray
    accel_rpm_s: np.ndarray
    torque_nm: np.ndarray
    theta_c: np.ndarray
    p_elec_w: np.ndarray

    @property
    def p_mech_w(self) -> np.ndarray:
        """Shaft power [W]."""
        return self.speed_rpm * self.torque_nm / RPM_PER_RAD_S

    def at(self, name: str, time_s) -> np.ndarray:
        """One signal interpolated linearly at ``time_s`` [s]."""
        return np.interp(time_s, self.time_s, getattr(self, name))


def _track(rate_hz: float, setpoint: np.ndarray, f_hz: float,
           zeta: float) -> tuple[np.ndarray, np.ndarray]:
    """A second-order loop's output and its rate following ``setpoint`` (sampled at
    ``rate_hz``, at rest before it), discretized by the bilinear transform."""
    wn = 2.0 * np.pi * f_hz
    den = [1.0, 2.0 * zeta * wn, wn**2]
    out = []
    for num in ([wn**2], [wn**2, 0.0]):  # the output, and its rate
        b, a = signal.bilinear(num, den, rate_hz)
        out.append(signal.lfilter(b, a, setpoint))
    return out[0], out[1]


def _winding(time_s, speed, torque, model: LossModel, bench: CycleBench) -> np.ndarray:
    """Winding temperature on ``time_s``: the loss held over each thermal step."""
    n_step = max(1, int(round(bench.thermal_step_s * bench.sim_rate_hz)))
    coarse = np.arange(0, time_s.size, n_step)
    theta = np.empty(coarse.size)
    th = bench.theta_start_c
    for k, i in enumerate(coarse.tolist()):
        theta[k] = th
        q = float(loss_w(speed[i], torque[i], th, model))
        th = float(theta_step(th, q, bench.ambient_c, bench.thermal_step_s, model))
    return np.interp(time_s, time_s[coarse], theta)


def run_signals(profile: DriveProfile, model: LossModel,
                bench: CycleBench = DEFAULT_CYCLE_BENCH) -> RunSignals:
    """The true signals of the bench flying ``profile`` (drum frame, DAQ clock).

    Parameters
    ----------
    profile : DriveProfile
        Its set-points, in its bench frame (carried to the drum frame here).
    model : LossModel
        The drive's true losses (the campaign's ``truth.json`` ``loss_model``).
    bench : CycleBench
        Loop bandwidths, inertia, thermal start, timing.
    """
    speed_set, torque_set = profile.drum()
    t_prof = profile.columns["time_s"]
    duration = bench.lead_s + float(t_prof[-1]) + bench.tail_s
    time = np.arange(int(np.floor(duration * bench.sim_rate_hz)) + 1) / bench.sim_rate_hz
    t_local = time - bench.lead_s
    n_set = np.interp(t_local, t_prof, speed_set, left=0.0, right=0.0)
    t_set = np.interp(t_local, t_prof, torque_set, left=0.0, right=0.0)
    speed, accel = _track(bench.sim_rate_hz, n_set, bench.speed_bandwidth_hz, bench.speed_zeta)
    torque, _ = _track(bench.sim_rate_hz, t_set, bench.torque_bandwidth_hz, bench.torque_zeta)
    torque = np.maximum(torque, 0.0)
    theta = _winding(time, speed, torque, model, bench)
    inertial = bench.inertia_kg_m2 * speed * accel / RPM_PER_RAD_S**2
    p_elec = true_p_elec_w(speed, torque, theta, model) + inertial
    return RunSignals(time, speed, accel, torque, theta, p_elec)


def cycle_truth(sig: RunSignals, profile: DriveProfile, bench: CycleBench) -> dict:
    """Per cycle of the profile (its set-point cycles, on the DAQ clock): bounds and the
    true electrical and mechanical energy [J], the mean winding temperature [degC]."""
    period = profile.period_s
    t0 = bench.lead_s + float(profile.header["cycle_start_s"])
    starts = t0 + period * np.arange(profile.n_cycles)
    out: dict[str, list] = {k: [] for k in ("cycle", "t_start_s", "t_end_s", "e_elec_j",
                                             "e_mech_j", "theta_mean_c")}
    p_mech = sig.p_mech_w
    for k, a in enumerate(starts.tolist()):
        out["cycle"].append(k)
        out["t_start_s"].append(round(a, 6))
        out["t_end_s"].append(round(a + period, 6))
        out["e_elec_j"].append(round(window_integral(sig.time_s, sig.p_elec_w, a, a + period), 4))
        out["e_mech_j"].append(round(window_integral(sig.time_s, p_mech, a, a + period), 4))
        out["theta_mean_c"].append(
            round(window_integral(sig.time_s, sig.theta_c, a, a + period) / period, 4))
    return out
