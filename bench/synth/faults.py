"""Unusable operating points: the few setpoints of every real bench session that go wrong.

Three faults, each put on a few setpoints of a timeseries session (a torque-only
step, never the first or last point, never next to another fault):

``brake hunting``
    Motor mode below 300 rpm, where the particle brake loads the drive: the
    brake stick-slips and the speed oscillates around its setpoint (a few rpm
    at about 2 Hz, growing in within half a second of the step). The flange
    sees the brake torque that drives the oscillation, ``-J domega/dt``.
``torque drift``
    The load cannot hold a high torque setpoint (the eddy-current brake in motor
    mode, the prime mover's torque control in generator mode, both heating up):
    one second after the step the torque starts to sag linearly until the next step.
``stepped early``
    The operator steps to the next setpoint before a steady window was logged:
    the setpoint is held for the torque-step settling time plus well under a second.

:func:`plan_faults` picks the setpoints and draws each fault's parameters;
:func:`speed_torque_offsets` gives the deviation from the setpoints they cause.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from kernel.units import RPM_PER_RAD_S

HUNTING = "brake hunting"
DRIFT = "torque drift"
EARLY = "stepped early"

#: faults per session mode
KINDS = {"motor": (HUNTING, DRIFT, EARLY), "generator": (DRIFT, EARLY)}

#: what each fault is, in one line (written to truth.json)
WHY = {
    HUNTING: "particle brake hunting at low speed: the speed oscillates through the window",
    DRIFT: "the load could not hold the torque setpoint: the torque sags through the window",
    EARLY: "the operator stepped to the next setpoint before a steady window was logged",
}


@dataclass(frozen=True)
class FaultConfig:
    """How many faults a session gets and how strong they are.

    Parameters
    ----------
    per_kind : int
        Faulty setpoints of each kind per sweep (``scale`` multiplies it) [-].
    hunting_max_speed_rpm : float
        Hunting only below this drum speed (the particle brake's range) [rpm].
    hunting_amp_rpm : tuple of float
        Range of the speed oscillation's amplitude [rpm].
    hunting_freq_hz : tuple of float
        Range of the oscillation's frequency [Hz].
    hunting_rise_s : float
        Time constant with which the oscillation grows in after the step [s].
    drift_min_torque_nm : float
        Drift only at torque setpoints of at least this [N m].
    drift_min_speed_rpm : float
        In motor mode, drift only at or above this |speed| (the eddy-current brake's range) [rpm].
    drift_rate_nm_s : tuple of float
        Range of the sag rate [N m / s].
    drift_delay_s : float
        Time after the step at which the torque starts to sag [s].
    early_steady_s : tuple of float
        Range of the time held after the settling time when stepping early [s].
    """

    per_kind: int = 2
    hunting_max_speed_rpm: float = 300.0
    hunting_amp_rpm: tuple[float, float] = (8.0, 14.0)
    hunting_freq_hz: tuple[float, float] = (1.6, 2.4)
    hunting_rise_s: float = 0.5
    drift_min_torque_nm: float = 20.0
    drift_min_speed_rpm: float = 300.0
    drift_rate_nm_s: tuple[float, float] = (0.6, 0.9)
    drift_delay_s: float = 1.0
    early_steady_s: tuple[float, float] = (0.25, 0.55)


DEFAULT_FAULTS = FaultConfig()


@dataclass(frozen=True)
class Faults:
    """Per-setpoint faults of one session (arrays over its operating points).

    Attributes: ``kind`` (``""`` for a good point, else one of :data:`KINDS`),
    ``hunting_amp_rpm``, ``hunting_freq_hz``, ``drift_rate_nm_s`` (0 where unused),
    ``early_steady_s`` (NaN where unused) and ``config``.
    """

    kind: np.ndarray
    hunting_amp_rpm: np.ndarray
    hunting_freq_hz: np.ndarray
    drift_rate_nm_s: np.ndarray
    early_steady_s: np.ndarray
    config: FaultConfig = DEFAULT_FAULTS

    @classmethod
    def none(cls, n: int, config: FaultConfig = DEFAULT_FAULTS) -> Faults:
        """No fault on any of ``n`` setpoints."""
        return cls(np.full(n, "", dtype=object), np.zeros(n), np.zeros(n), np.zeros(n),
                   np.full(n, np.nan), config)

    @property
    def good(self) -> np.ndarray:
        """True for the setpoints without a fault."""
        return self.kind == ""


def _candidates(kind: str, mode: str, speed, torque, cfg: FaultConfig) -> np.ndarray:
    n = speed.size
    k = np.arange(n)
    ok = (k >= 1) & (k <= n - 2)
    ok[1:] &= speed[1:] == speed[:-1]  # a torque-only step
    if kind == HUNTING:
        ok &= np.abs(speed) < cfg.hunting_max_speed_rpm
    elif kind == DRIFT:
        ok &= torque >= cfg.drift_min_torque_nm
        if mode == "motor":
            ok &= np.abs(speed) >= cfg.drift_min_speed_rpm
    return ok


def plan_faults(mode: str, speed_rpm, torque_nm, scale: int, rng: np.random.Generator,
                cfg: FaultConfig = DEFAULT_FAULTS) -> Faults:
    """Pick the faulty setpoints of a timeseries session and draw their parameters.

    Parameters
    ----------
    mode : str
        ``"motor"`` or ``"generator"`` (which faults apply, see :data:`KINDS`).
    speed_rpm, torque_nm : numpy.ndarray
        Setpoints in visiting order, drum frame [rpm], [N m].
    scale : int
        Sweeps in the session: each kind gets ``per_kind * scale`` setpoints.
    rng : numpy.random.Generator
        Source of the choice and the parameters.
    cfg : FaultConfig
        Counts and strengths.
    """
    speed = np.asarray(speed_rpm, dtype=float)
    torque = np.asarray(torque_nm, dtype=float)
    f = Faults.none(speed.size, cfg)
    taken = np.zeros(speed.size, dtype=bool)  # a fault or next to one
    for kind in KINDS[mode]:
        free = np.flatnonzero(_candidates(kind, mode, speed, torque, cfg) & ~taken)
        chosen = 0
        for i in rng.permutation(free):
            if chosen == cfg.per_kind * scale:
                break
            if taken[i]:
                continue
            chosen += 1
            f.kind[i] = kind
            taken[max(i - 1, 0):i + 2] = True
            if kind == HUNTING:
                f.hunting_amp_rpm[i] = rng.uniform(*cfg.hunting_amp_rpm)
                f.hunting_freq_hz[i] = rng.uniform(*cfg.hunting_freq_hz)
            elif kind == DRIFT:
                f.drift_rate_nm_s[i] = rng.uniform(*cfg.drift_rate_nm_s)
            else:
                f.early_steady_s[i] = rng.uniform(*cfg.early_steady_s)
    return f


def speed_torque_offsets(f: Faults, k: np.ndarray, tau_s: np.ndarray, inertia_kg_m2: float):
    """Deviation from the setpoints caused by the faults, at ``tau_s`` after step ``k``.

    Parameters
    ----------
    f : Faults
        The session's faults.
    k : numpy.ndarray
        Segment (setpoint) index of each time.
    tau_s : numpy.ndarray
        Time since that segment's step [s].
    inertia_kg_m2 : float
        Rotating inertia at the drum [kg m^2] (hunting: the brake torque that swings it).

    Returns
    -------
    d_speed_rpm, d_accel_rpm_s, d_torque_nm : numpy.ndarray
        Speed deviation [rpm], its rate [rpm/s] and the torque deviation [N m].
    """
    tau = np.asarray(tau_s, dtype=float)
    d_speed = np.zeros_like(tau)
    d_accel = np.zeros_like(tau)
    d_torque = np.zeros_like(tau)
    hunt = f.hunting_amp_rpm[k] > 0.0
    if hunt.any():
        t, amp, w = tau[hunt], f.hunting_amp_rpm[k[hunt]], 2.0 * np.pi * f.hunting_freq_hz[k[hunt]]
        decay = np.exp(-t / f.config.hunting_rise_s)
        d_speed[hunt] = amp * (1.0 - decay) * np.sin(w * t)
        d_accel[hunt] = amp * (decay / f.config.hunting_rise_s * np.sin(w * t)
                               + (1.0 - decay) * w * np.cos(w * t))
        d_torque[hunt] = -inertia_kg_m2 * d_accel[hunt] / RPM_PER_RAD_S
    drift = f.drift_rate_nm_s[k] > 0.0
    if drift.any():
        d_torque[drift] -= f.drift_rate_nm_s[k[drift]] * np.maximum(
            tau[drift] - f.config.drift_delay_s, 0.0)
    return d_speed, d_accel, d_torque
