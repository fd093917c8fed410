"""What the bench instruments log: DAQ (speed, torque), power analyzer, averaged tables.

Each function turns the true signals of :mod:`bench.synth.true_signals` into one
chunk of an instrument's records: sample clock, sensor side and sign, zero offset,
noise, averaging and lag, quantization and the occasional invalid-value marker.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

from bench.synth.loss_model import LossModel
from bench.synth.plan import GEAR_RATIO, SessionSpec
from bench.synth.true_signals import Segments, true_signals
from kernel.units import RPM_PER_RAD_S

#: the overflow value many instruments write for an invalid reading
OVERFLOW = 9.91e37


@dataclass(frozen=True)
class Instruments:
    """Sample rates and error model of the bench instruments.

    Parameters
    ----------
    daq_rate_hz : float
        DAQ sample rate [Hz].
    analyzer_interval_s : float
        Power-analyzer update interval on its own clock [s].
    speed_noise_rpm : float
        Speed-sensor white noise, constant part [rpm] (at the measured shaft).
    speed_noise_rel : float
        Speed-sensor white noise, part proportional to the speed [-].
    torque_noise_nm : float
        Torque-sensor white noise [N m] (at the measured shaft).
    torque_zero_offset_nm : float
        Torque-flange zero offset, added to the logged torque [N m].
    speed_decimals : int
        DAQ speed resolution, decimals of the logged unit [-] (2: 0.01 rpm).
    torque_decimals : int
        DAQ torque resolution, decimals of the logged unit [-] (3: 0.001 N m).
    analyzer_subsamples : int
        Sub-samples averaged over each analyzer interval [-].
    analyzer_tau_s : float
        First-order time constant of the analyzer's power measurement [s].
    power_noise_w : float
        Analyzer white noise, constant part [W].
    power_noise_rel : float
        Analyzer white noise, part proportional to the power [-].
    power_lsb_w : float
        Analyzer power resolution [W].
    grid_voltage_v : float
        Line-to-line grid voltage [V].
    reactive_power_var : float
        Reactive power of the drive's line side at no load [var].
    daq_marker_rate : float
        Probability that a DAQ row holds one invalid-value marker [-].
    analyzer_marker_rate : float
        Probability that an analyzer row holds one invalid-value marker [-].
    winding_noise_k : float
        Winding-temperature sensor white noise [K].
    winding_lag_s : float
        First-order time constant of the winding sensor [s].
    winding_decimals : int
        DAQ resolution of the winding temperature, decimals of degC or K [-].
    """

    daq_rate_hz: float = 50.0
    analyzer_interval_s: float = 0.1
    speed_noise_rpm: float = 0.4
    speed_noise_rel: float = 2.0e-4
    torque_noise_nm: float = 0.06
    torque_zero_offset_nm: float = 0.15
    speed_decimals: int = 2
    torque_decimals: int = 3
    analyzer_subsamples: int = 4
    analyzer_tau_s: float = 0.2
    power_noise_w: float = 4.0
    power_noise_rel: float = 5.0e-4
    power_lsb_w: float = 1.0
    grid_voltage_v: float = 400.0
    reactive_power_var: float = 350.0
    daq_marker_rate: float = 1.0 / 3000.0
    analyzer_marker_rate: float = 1.0 / 2000.0
    winding_noise_k: float = 0.2
    winding_lag_s: float = 8.0
    winding_decimals: int = 2


DEFAULT_INSTRUMENTS = Instruments()


class ChunkRandom:
    """Random streams of one instrument file, each consumed in sample order.

    Every quantity draws from its own generator, one value per row, so a file's
    content does not depend on how it is cut into chunks.

    Parameters
    ----------
    seed : sequence of int
        Entropy for :class:`numpy.random.SeedSequence`.
    """

    def __init__(self, seed):
        noise_a, noise_b, hit, pick = (np.random.default_rng(s)
                                       for s in np.random.SeedSequence(seed).spawn(4))
        self.noise_a = noise_a  # first noisy channel
        self.noise_b = noise_b  # second noisy channel
        self._hit = hit
        self._pick = pick
        self._last_hit = False

    def marker_cells(self, n_rows: int, columns: tuple[int, ...], n_kinds: int,
                     rate: float) -> dict[int, tuple[np.ndarray, np.ndarray]]:
        """Pick isolated invalid cells of the next ``n_rows``: ``{column: (rows, codes)}``.

        A row holds at most one marker and a row right after a hit is never hit, so
        an invalid value is always a single sample, never a run.
        """
        hit = self._hit.random(n_rows) < rate
        pick = np.floor(self._pick.random(n_rows) * (len(columns) * n_kinds)).astype(np.int64)
        after_hit = np.concatenate([[self._last_hit], hit[:-1]])
        self._last_hit = bool(hit[-1]) if n_rows else self._last_hit
        rows = np.flatnonzero(hit & ~after_hit)
        col, code = np.divmod(pick[rows], n_kinds)
        return {c: (rows[col == i], code[col == i]) for i, c in enumerate(columns)}


def logged_speed_torque(speed_rpm, torque_nm, spec: SessionSpec):
    """Drum-frame speed and torque as the session's sensors see them (side and sign)."""
    speed = np.asarray(speed_rpm, dtype=float)
    torque = np.asarray(torque_nm, dtype=float)
    if spec.measured_side == "motor":
        speed, torque = speed * GEAR_RATIO, torque / GEAR_RATIO
    return speed * spec.speed_sign, torque * spec.torque_sign


def torque_offset_drum_nm(spec: SessionSpec, inst: Instruments = DEFAULT_INSTRUMENTS) -> float:
    """The flange zero offset as it appears in the drum-frame torque [N m]."""
    gear = GEAR_RATIO if spec.measured_side == "motor" else 1.0
    return inst.torque_zero_offset_nm * spec.torque_sign * gear


def daq_chunk(seg: Segments, rows: slice, spec: SessionSpec, model: LossModel,
              rnd: ChunkRandom, inst: Instruments = DEFAULT_INSTRUMENTS):
    """DAQ rows ``rows.start .. rows.stop - 1``: time [s], logged speed, logged torque,
    true winding temperature [degC] (the sensor's input, :mod:`bench.synth.winding_sensor`).

    The DAQ clock is the reference clock of the truth; its samples sit on an
    exact ``1 / daq_rate_hz`` grid.
    """
    time_s = np.arange(rows.start, rows.stop) / inst.daq_rate_hz
    sig = true_signals(seg, time_s, model)
    speed, torque = logged_speed_torque(sig["speed_rpm"], sig["torque_nm"], spec)
    sd = inst.speed_noise_rpm + inst.speed_noise_rel * np.abs(speed)
    speed = speed + sd * rnd.noise_a.standard_normal(time_s.size)
    noise = inst.torque_noise_nm * rnd.noise_b.standard_normal(time_s.size)
    torque = torque + inst.torque_zero_offset_nm + noise
    # the DAQ's resolution (this also makes TDMS bytes immune to last-bit differences
    # of the platform's exp/sin/cos)
    speed = np.round(speed, inst.speed_decimals)
    torque = np.round(torque, inst.torque_decimals)
    return time_s, speed, torque, sig["theta_c"]


def analyzer_rows(seg: Segments, spec: SessionSpec, inst: Instruments = DEFAULT_INSTRUMENTS) -> int:
    """Number of analyzer records within the session."""
    rate = inst.analyzer_interval_s * (1.0 + spec.analyzer_drift_ppm * 1e-6)
    return int(np.floor((seg.duration_s - spec.analyzer_delay_s) / rate)) + 1


def analyzer_chunk(seg: Segments, rows: slice, spec: SessionSpec, model: LossModel,
                   rnd: ChunkRandom, state, inst: Instruments = DEFAULT_INSTRUMENTS):
    """Analyzer records ``rows``: its own time [s], Urms [V], Irms [A], P [W], PF [-].

    Each record is the mean true electrical power over the analyzer's interval,
    passed through a first-order lag, plus noise, quantized to ``power_lsb_w``.

    Parameters
    ----------
    state : numpy.ndarray or None
        Lag-filter state from the previous chunk (``None`` for the first).

    Returns
    -------
    columns : tuple of numpy.ndarray
        ``(time_s, urms_v, irms_a, p_w, pf)``.
    state : numpy.ndarray
        Filter state for the next chunk.
    """
    dt = inst.analyzer_interval_s
    time_s = np.arange(rows.start, rows.stop) * dt
    rate = 1.0 + spec.analyzer_drift_ppm * 1e-6
    t_true = spec.analyzer_delay_s + time_s * rate
    m = inst.analyzer_subsamples
    back = (np.arange(m) + 0.5) / m * dt * rate
    sub = np.clip(t_true[:, None] - back[None, :], 0.0, seg.duration_s)
    p_true = true_signals(seg, sub.ravel(), model)["p_elec_w"].reshape(sub.shape).mean(axis=1)
    a = np.exp(-dt / inst.analyzer_tau_s)
    if state is None:
        state = signal.lfilter_zi([1.0 - a], [1.0, -a]) * p_true[0]
    p_lag, state = signal.lfilter([1.0 - a], [1.0, -a], p_true, zi=state)
    sd = inst.power_noise_w + inst.power_noise_rel * np.abs(p_lag)
    p = p_lag + sd * rnd.noise_a.standard_normal(time_s.size)
    p = np.round(p / inst.power_lsb_w) * inst.power_lsb_w
    u = inst.grid_voltage_v * (1.0 + 0.004 * np.sin(2.0 * np.pi * t_true / 900.0))
    u = u + 0.05 * rnd.noise_b.standard_normal(time_s.size)
    q = inst.reactive_power_var + 0.03 * np.abs(p)
    s = np.hypot(p, q)
    irms = s / (np.sqrt(3.0) * u)
    pf = p / s
    return (time_s, u, irms, p, pf), state


def averaged_table(seg: Segments, truth: dict, spec: SessionSpec, rng: np.random.Generator,
                   inst: Instruments = DEFAULT_INSTRUMENTS) -> dict[str, np.ndarray]:
    """The bench software's table of averaged points (drum frame, the sensors' errors).

    Means carry the noise of averaging ``N`` samples and the torque-flange offset;
    standard deviations are those of ``N`` noisy samples.

    Parameters
    ----------
    truth : dict
        :func:`bench.synth.true_signals.window_means` of the session.

    Returns
    -------
    dict of numpy.ndarray
        ``speed_rpm``, ``speed_std_rpm``, ``torque_nm``, ``torque_std_nm``,
        ``p_elec_w``, ``p_elec_std_w``, ``p_mech_w``, ``n_samples``.
    """
    width = seg.t_end_s - seg.t_steady_s
    n_daq = np.floor(width * inst.daq_rate_hz).astype(np.int64)
    n_an = np.floor(width / inst.analyzer_interval_s).astype(np.int64)

    def scatter(sd, n):
        return sd * np.sqrt(rng.chisquare(n - 1) / (n - 1))

    sd_n = inst.speed_noise_rpm + inst.speed_noise_rel * np.abs(truth["speed_rpm"])
    speed = truth["speed_rpm"] + sd_n / np.sqrt(n_daq) * rng.standard_normal(n_daq.size)
    torque = (truth["torque_nm"] + torque_offset_drum_nm(spec, inst)
              + inst.torque_noise_nm / np.sqrt(n_daq) * rng.standard_normal(n_daq.size))
    sd_p = inst.power_noise_w + inst.power_noise_rel * np.abs(truth["p_elec_w"])
    p_elec = truth["p_elec_w"] + sd_p / np.sqrt(n_an) * rng.standard_normal(n_an.size)
    return {
        "speed_rpm": speed,
        "speed_std_rpm": scatter(sd_n, n_daq),
        "torque_nm": torque,
        "torque_std_nm": scatter(inst.torque_noise_nm, n_daq),
        "p_elec_w": p_elec,
        "p_elec_std_w": scatter(sd_p, n_an),
        "p_mech_w": speed / RPM_PER_RAD_S * torque,
        "n_samples": n_daq,
    }
