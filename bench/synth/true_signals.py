"""True signals of a bench session: setpoint steps, transients, winding temperature.

Time here is the DAQ clock (the reference of the synthetic truth). A session is a
sequence of segments, one per operating point: the setpoints step at the segment
start, speed and torque settle as second-order systems, and the last part of the
segment is the steady window the truth averages over. Everything is a closed-form
function of time, so any sample range can be evaluated on its own (chunked
generation); only the winding temperature needs a recurrence, and that one runs
per segment, not per sample.

A timeseries session starts at standstill with no load (the operator's tare of the
torque flange) until the first step; the few faulty setpoints of
:mod:`bench.synth.faults` add their deviations on top of the step responses.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from bench.synth.faults import Faults, speed_torque_offsets
from bench.synth.loss_model import LossModel, loss_w, theta_step, true_p_elec_w
from kernel.units import RPM_PER_RAD_S


@dataclass(frozen=True)
class Dynamics:
    """Closed-loop dynamics of the bench and the step timing.

    Parameters
    ----------
    speed_wn_rad_s : float
        Natural frequency of the speed loop [rad/s].
    speed_zeta : float
        Damping ratio of the speed loop [-].
    torque_wn_rad_s : float
        Natural frequency of the torque (brake / prime mover) loop [rad/s].
    torque_zeta : float
        Damping ratio of the torque loop [-] (underdamped: overshoot on steps).
    inertia_kg_m2 : float
        Rotating inertia reflected to the drum shaft [kg m^2]; accelerating it
        draws ``J omega domega/dt`` from the grid (the power spike on speed steps).
    settle_torque_step_s : float
        Settling time the operator waits after a torque-only step [s].
    settle_speed_step_s : float
        Extra settling time after a speed step [s].
    settle_jitter_s : float
        Random extra settling time, uniform in [0, this] [s].
    steady_s : float
        Minimum steady (averaging) window [s].
    steady_jitter_s : float
        Random extra steady time, uniform in [0, this] [s].
    tare_s : float
        Minimum standstill at the start of a timeseries session (flange tare) [s].
    tare_jitter_s : float
        Random extra standstill, uniform in [0, this] [s].
    """

    speed_wn_rad_s: float = 4.0
    speed_zeta: float = 0.8
    torque_wn_rad_s: float = 9.0
    torque_zeta: float = 0.45
    inertia_kg_m2: float = 0.06
    settle_torque_step_s: float = 2.0
    settle_speed_step_s: float = 1.5
    settle_jitter_s: float = 0.5
    steady_s: float = 4.0
    steady_jitter_s: float = 1.0
    tare_s: float = 8.0
    tare_jitter_s: float = 2.0


DEFAULT_DYNAMICS = Dynamics()


@dataclass(frozen=True)
class Segments:
    """Per-operating-point timeline of one session (DAQ clock, drum frame).

    Attributes are arrays over segments: ``t_start_s`` (setpoint step), ``t_steady_s``
    (steady window start), ``t_end_s`` (window end = next step), ``speed_rpm`` and
    ``torque_nm`` (setpoints), ``speed_prev_rpm`` and ``torque_prev_nm`` (the
    values stepped from: the previous setpoints, or what a fault left of them; 0 for
    the first step of a session that starts at standstill), ``theta_start_c``
    (winding temperature at the step), ``loss_w`` (heat input held over the
    segment) and ``faults``. Before ``t_start_s[0]`` the drive stands still
    without load (the tare; zero length for sessions without one).
    """

    t_start_s: np.ndarray
    t_steady_s: np.ndarray
    t_end_s: np.ndarray
    speed_rpm: np.ndarray
    torque_nm: np.ndarray
    speed_prev_rpm: np.ndarray
    torque_prev_nm: np.ndarray
    theta_start_c: np.ndarray
    loss_w: np.ndarray
    ambient_c: float
    faults: Faults

    @property
    def duration_s(self) -> float:
        """Length of the session [s]."""
        return float(self.t_end_s[-1])


def schedule(speed_rpm, torque_nm, rng: np.random.Generator, dyn: Dynamics = DEFAULT_DYNAMICS,
             *, tare: bool = False, early_steady_s=None):
    """Step times of a session: ``(t_start_s, t_steady_s, t_end_s)`` arrays [s].

    Without ``tare`` the first point is already settled when logging starts, so its
    segment has no transient; with it, logging starts with a standstill of
    ``tare_s`` plus jitter and the first point is a speed step from 0. Later
    segments wait longer after a speed step than after a torque step.
    ``early_steady_s`` (NaN where unused) replaces the steady time of the setpoints
    the operator left early (:mod:`bench.synth.faults`).
    """
    speed = np.asarray(speed_rpm, dtype=float)
    prev = np.concatenate([[0.0] if tare else speed[:1], speed[:-1]])
    settle = (
        dyn.settle_torque_step_s
        + dyn.settle_speed_step_s * (np.abs(speed - prev) > 0.5)
        + rng.uniform(0.0, dyn.settle_jitter_s, speed.size)
    )
    steady = dyn.steady_s + rng.uniform(0.0, dyn.steady_jitter_s, speed.size)
    t0 = dyn.tare_s + rng.uniform(0.0, dyn.tare_jitter_s) if tare else 0.0
    if early_steady_s is not None:
        early = np.isfinite(early_steady_s)
        settle[early] = dyn.settle_torque_step_s
        steady[early] = np.asarray(early_steady_s)[early]
    ends = t0 + np.cumsum(settle + steady)
    starts = np.concatenate([[t0], ends[:-1]])
    return starts, starts + settle, ends


def thermal_history(segments_time, speed_rpm, torque_nm, theta0_c, ambient_c,
                    model: LossModel):
    """Winding temperature at each step and the loss held over each segment.

    One iteration per segment (not per sample): the loss at the segment's
    setpoints and starting temperature heats the winding for the segment's length.

    Returns
    -------
    theta_start_c, loss_w : numpy.ndarray
        [degC] and [W] per segment.
    """
    t_start, _, t_end = segments_time
    n = np.asarray(speed_rpm, dtype=float)
    t = np.asarray(torque_nm, dtype=float)
    # the loss is affine in theta (copper term): loss = base + slope * theta
    base = loss_w(n, t, 0.0, model)
    slope = loss_w(n, t, 1.0, model) - base
    decay = np.exp(-(t_end - t_start) / model.tau_th_s).tolist()
    r_th = model.r_th_k_per_w
    theta = np.empty(n.size)
    th = float(theta0_c)
    for k, (b, a, d) in enumerate(zip(base.tolist(), slope.tolist(), decay, strict=True)):
        theta[k] = th
        # exact first-order step with the loss held at its value at the segment start
        theta_ss = ambient_c + r_th * (b + a * th)
        th = theta_ss + (th - theta_ss) * d
    loss = base + slope * theta
    return theta, loss


def build_segments(speed_rpm, torque_nm, times, theta0_c, ambient_c, model: LossModel,
                   faults: Faults | None = None, *, tare: bool = False,
                   dyn: Dynamics = DEFAULT_DYNAMICS):
    """Assemble :class:`Segments` from setpoints, step times, faults and the thermal model.

    Each step starts from where the previous segment ended (its setpoints plus
    what its fault left), from standstill for the first step after a ``tare``.
    """
    speed = np.asarray(speed_rpm, dtype=float)
    torque = np.asarray(torque_nm, dtype=float)
    faults = Faults.none(speed.size) if faults is None else faults
    theta, loss = thermal_history(times, speed, torque, theta0_c, ambient_c, model)
    k = np.arange(speed.size)
    d_n, _, d_t = speed_torque_offsets(faults, k, times[2] - times[0], dyn.inertia_kg_m2)
    first = [0.0] if tare else None
    return Segments(
        t_start_s=times[0], t_steady_s=times[1], t_end_s=times[2],
        speed_rpm=speed, torque_nm=torque,
        speed_prev_rpm=np.concatenate([first or speed[:1], (speed + d_n)[:-1]]),
        torque_prev_nm=np.concatenate([first or torque[:1], (torque + d_t)[:-1]]),
        theta_start_c=theta, loss_w=loss, ambient_c=float(ambient_c), faults=faults,
    )


#: a transient is over (and not evaluated) once its envelope is below this fraction
TAIL_NEGLIGIBLE = 1e-9


def _step_tail(tau_s, step, wn, zeta):
    """What is left of a step ``step`` of a second-order system ``tau_s`` after it, and its rate.

    Evaluated only where the step is non-zero and its envelope not yet below
    :data:`TAIL_NEGLIGIBLE` (most samples sit in settled segments).
    """
    tail = np.zeros_like(tau_s)
    rate = np.zeros_like(tau_s)
    live = (step != 0.0) & (tau_s < -np.log(TAIL_NEGLIGIBLE) / (zeta * wn))
    tau, a = tau_s[live], step[live]
    root = np.sqrt(1.0 - zeta**2)
    env = np.exp(-zeta * wn * tau)
    c, s = np.cos(wn * root * tau), np.sin(wn * root * tau)
    tail[live] = a * env * (c + zeta / root * s)
    rate[live] = -a * env * wn / root * s
    return tail, rate


def true_signals(seg: Segments, time_s, model: LossModel, dyn: Dynamics = DEFAULT_DYNAMICS):
    """True drum speed, torque, winding temperature and electrical power at ``time_s``.

    Parameters
    ----------
    seg : Segments
        The session's timeline.
    time_s : numpy.ndarray
        Times on the DAQ clock [s], within ``[0, seg.duration_s]``.
    model : LossModel
        The (calibrated) loss model.
    dyn : Dynamics
        Bench dynamics.

    Returns
    -------
    dict of numpy.ndarray
        ``speed_rpm``, ``torque_nm``, ``theta_c``, ``p_elec_w`` (steady loss model
        plus the power that accelerates the inertia).
    """
    t = np.asarray(time_s, dtype=float)
    k = np.clip(np.searchsorted(seg.t_start_s, t, side="right") - 1, 0, seg.t_start_s.size - 1)
    standstill = t < seg.t_start_s[0]  # before the first step: the tare
    tau = np.maximum(t - seg.t_start_s[k], 0.0)
    tail_n, accel_rpm_s = _step_tail(tau, seg.speed_prev_rpm[k] - seg.speed_rpm[k],
                                     dyn.speed_wn_rad_s, dyn.speed_zeta)
    tail_t, _ = _step_tail(tau, seg.torque_prev_nm[k] - seg.torque_nm[k],
                           dyn.torque_wn_rad_s, dyn.torque_zeta)
    d_n, d_accel, d_t = speed_torque_offsets(seg.faults, k, tau, dyn.inertia_kg_m2)
    speed = seg.speed_rpm[k] + tail_n + d_n
    accel_rpm_s = accel_rpm_s + d_accel
    torque = np.maximum(seg.torque_nm[k] + tail_t + d_t, 0.0)
    speed[standstill] = accel_rpm_s[standstill] = torque[standstill] = 0.0
    theta = theta_step(seg.theta_start_c[k], seg.loss_w[k], seg.ambient_c, tau, model)
    inertial = dyn.inertia_kg_m2 * speed * accel_rpm_s * RPM_PER_RAD_S**-2
    p_elec = true_p_elec_w(speed, torque, theta, model) + inertial
    return {"speed_rpm": speed, "torque_nm": torque, "theta_c": theta, "p_elec_w": p_elec}


def window_means(seg: Segments, model: LossModel, dyn: Dynamics = DEFAULT_DYNAMICS,
                 nodes: int = 32) -> dict[str, np.ndarray]:
    """True means over every steady window (midpoint rule on ``nodes`` points).

    Returns
    -------
    dict of numpy.ndarray
        Per point: ``speed_rpm``, ``torque_nm``, ``p_mech_w``, ``p_elec_w``, ``theta_c``.
    """
    frac = (np.arange(nodes) + 0.5) / nodes
    width = seg.t_end_s - seg.t_steady_s
    times = seg.t_steady_s[:, None] + width[:, None] * frac[None, :]
    sig = true_signals(seg, times.ravel(), model, dyn)
    out = {name: sig[name].reshape(times.shape).mean(axis=1)
           for name in ("speed_rpm", "torque_nm", "p_elec_w", "theta_c")}
    p_mech = (sig["speed_rpm"] * sig["torque_nm"]).reshape(times.shape) / RPM_PER_RAD_S
    out["p_mech_w"] = p_mech.mean(axis=1)
    return out
