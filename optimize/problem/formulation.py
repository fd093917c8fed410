"""The periodic pumping-cycle OCP in continuous time (paper section IV, eq. 5).

What is optimized and subject to what, independent of how it is transcribed
(:mod:`optimize.problem.transcription`): the kite DAE, its path constraints at a
point of the cycle, the conditions at the cycle's start and between its start and
end (invariants, periodicity), the cycle averages and the objective, and the
bounds of the variables. Everything is returned scaled (each expression divided
by its typical size, :mod:`optimize.problem.scaling`).

A constraint row is a :class:`Row`: a name, a scaled expression and its bounds,
with separate bounds when the drive limits apply (the ``*-lim`` scenarios). A
new path constraint is one more :class:`Row` in :meth:`Formulation.point`; the
transcriptions place it at every collocation point and find it by its name.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from optimize.model import kite_model as km
from optimize.model.drive import (
    DriveModel,
    max_reel_speed_m_s,
    mechanical_power_w,
    motor_speed_rpm,
    motor_torque_nm,
)
from optimize.model.kite_model import KiteDae
from optimize.problem.options import Discretization, Limits
from optimize.problem.scaling import Scales

# ---- named parts of the state, algebraic and control vectors
#: body-to-world DCM entries (column-major) in the state
X_DCM = slice(km.IDX["dcm_11"], km.IDX["dcm_33"] + 1)
#: tether length and reel-out speed in the state
X_LENGTH, X_REEL_SPEED = km.IDX["l_m"], km.IDX["dl_m_s"]
#: the tether multiplier ``nu`` [N/m] in the algebraic variables (tension = l nu)
Z_NU = km.ALGEBRAIC_NAMES.index("nu_n_m")
#: tether jerk and the control-surface rates in the controls
U_JERK = km.CONTROL_NAMES.index("dddl_m_s3")
U_SURFACE_RATES = slice(U_JERK + 1, km.NU)

#: periodic state components (the DCM is periodic through :data:`X_DCM` rows)
PERIODIC_STATES = (
    "r_y_m", "r_z_m", "v_y_m_s", "v_z_m_s", "omega_x_rad_s", "omega_y_rad_s",
    "omega_z_rad_s", "l_m", "dl_m_s", "ddl_m_s2", "aileron_rad", "elevator_rad", "rudder_rad",
)
#: scalar NLP parameters: wind at 100 m, objective and homotopy weights
PARAM_NAMES = ("wind_ref_m_s", "w_elec", "w_mech", "w_reg", "w_track", "w_fict")

DEG = np.pi / 180


@dataclass(frozen=True)
class Row:
    """Constraint rows ``lo <= expr <= hi`` (scaled).

    Attributes
    ----------
    name : str
        What the rows constrain (the transcription's index of the rows).
    expr : casadi.SX
        Column of scaled expressions.
    lo, hi : float
        Bounds (each row the same) without the drive limits.
    limited : (float, float) or None
        Bounds when the drive limits apply; ``None``: the same as ``(lo, hi)``.
    """

    name: str
    expr: Any
    lo: float = 0.0
    hi: float = 0.0
    limited: tuple[float, float] | None = None


@dataclass(frozen=True)
class Point:
    """What the formulation asks of one collocation point: its constraint rows and
    the integrands of the cycle averages."""

    rows: list[Row]
    p_elec_w: Any
    p_mech_w: Any
    torque_sq: Any  # (motor torque / torque scale)^2
    fict_sq: Any  # sum of the squared scaled fictitious forces and moments


@dataclass(frozen=True)
class Formulation:
    """The cycle OCP of one system and drive model (pure: builds expressions only).

    Parameters
    ----------
    dae : KiteDae
    drive_model : DriveModel
        Electrical power model of the drive.
    limits : Limits
        Bounds of the system and its drive.
    discretization : Discretization
        For the control regularization's weight and scales.
    scales : Scales
    """

    dae: KiteDae
    drive_model: DriveModel
    limits: Limits
    discretization: Discretization
    scales: Scales

    # ---------------------------------------------------------------- dynamics
    def ode(self, x: Any, u: Any, z: Any) -> Any:
        """Explicit part of the DAE ``xdot = f(x, u, z)`` (physical units)."""
        return self.dae.ode(x, u, z)

    def tension_n(self, x: Any, z: Any) -> Any:
        """Tether tension [N]."""
        return x[X_LENGTH] * z[Z_NU]

    def kite_limits(self) -> tuple[float, float]:
        """Upper bounds of the airspeed [m/s] and motor-torque [N m] rows in every kind.

        The kite's airspeed limit and its tether-force limit, the latter as the motor
        torque that holds that tension on the drum (``inf`` where none is given). The
        drive's torque limit of the ``*-lim`` kinds comes on top (the smaller wins);
        the rows are those of the NLP without kite limits, so a stored initial guess
        still fits.
        """
        lim, kite = self.limits, self.dae.kite
        v_top = np.inf if lim.max_airspeed_m_s is None else lim.max_airspeed_m_s
        torque_top = (np.inf if lim.max_tether_force_n is None else float(
            motor_torque_nm(lim.max_tether_force_n, kite.r_winch_m, kite.gear_ratio)))
        return v_top, torque_top

    # ---------------------------------------------------------------- one point
    def point(self, x: Any, u: Any, z: Any, fict: Any, wind: Any) -> Point:
        """Rows and integrands at one collocation point (physical ``x, u, z, fict``)."""
        lim, sc = self.limits, self.scales
        kite = self.dae.kite
        r_w, gear = kite.r_winch_m, kite.gear_ratio
        out = dict(zip(self.dae.outputs.name_out(), self.dae.outputs(x, u, z, wind),
                       strict=True))
        tension = self.tension_n(x, z)
        dl = x[X_REEL_SPEED]
        torque = motor_torque_nm(tension, r_w, gear)
        p_elec = self.drive_model.casadi_p_elec_w(motor_speed_rpm(dl, r_w, gear), torque)
        v_sc = sc.airspeed_m_s
        v_top, torque_top = self.kite_limits()
        rows = [
            Row("algebraic", self.dae.alg(x, u, z, wind, fict) * ca.DM(1.0 / sc.residual)),
            Row("airspeed", out["airspeed_m_s"] / v_sc, lim.min_airspeed_m_s / v_sc,
                v_top / v_sc),
            Row("alpha", out["alpha_rad"] / (10 * DEG), lim.alpha_bounds_deg[0] / 10,
                lim.alpha_bounds_deg[1] / 10),
            Row("beta", out["beta_rad"] / (10 * DEG), lim.beta_bounds_deg[0] / 10,
                lim.beta_bounds_deg[1] / 10),
            Row("line_angle", out["cos_line_angle"], np.cos(lim.max_line_angle_deg * DEG),
                np.inf),
            Row("torque", torque / sc.torque_nm, -np.inf, torque_top / sc.torque_nm,
                limited=(-np.inf, min(lim.max_torque_nm, torque_top) / sc.torque_nm)),
        ]
        if lim.max_p_elec_w is not None:
            p_lim = lim.max_p_elec_w / sc.power_w
            rows.append(Row("p_elec", p_elec / sc.power_w, -np.inf, np.inf,
                            limited=(-p_lim, p_lim)))
        return Point(
            rows=rows,
            p_elec_w=p_elec,
            p_mech_w=mechanical_power_w(tension, dl),
            torque_sq=(torque / sc.torque_nm) ** 2,
            fict_sq=ca.sumsqr(fict / ca.DM(sc.fictitious)),
        )

    def control_cost(self, u: Any) -> Any:
        """Regularization term of one interval's control ``sum_i (u_i / sigma_i)^2``."""
        return ca.sumsqr(u / ca.DM(self.discretization.control_sigma))

    # ---------------------------------------------------------------- cycle
    def start_rows(self, x0: Any) -> list[Row]:
        """Invariants at t = 0: tether constraint, its rate, an orthonormal DCM."""
        sc = self.scales
        c0, cdot0, orth0 = self.dae.invariants(x0)
        return [
            Row("invariant_c", c0 / sc.c_m2),
            Row("invariant_cdot", cdot0 / sc.cdot_m2_s),
            Row("orthonormal", ca.vertcat(*[orth0[a, b] for a in range(3) for b in range(a, 3)])),
        ]

    def periodicity_rows(self, x0: Any, x_end: Any) -> list[Row]:
        """The cycle closes: periodic states and the DCM's relative rotation."""
        per = [km.IDX[name] for name in PERIODIC_STATES]
        dcm0 = ca.reshape(x0[X_DCM], 3, 3)
        rel = ca.mtimes(dcm0.T, ca.reshape(x_end[X_DCM], 3, 3))
        return [
            Row("periodic", (x_end[per] - x0[per]) * ca.DM(1.0 / self.scales.state[per])),
            Row("periodic", ca.vertcat(rel[0, 1], rel[0, 2], rel[1, 2])),
        ]

    def average_rows(self, torque_sq_avg: Any) -> list[Row]:
        """Rows on cycle averages: the drive's RMS torque rating, when it has one."""
        lim = self.limits
        if lim.max_rms_torque_nm is None:
            return []
        return [Row("rms_torque", torque_sq_avg, -np.inf, np.inf,
                    limited=(-np.inf, (lim.max_rms_torque_nm / self.scales.torque_nm) ** 2))]

    def objective(self, weights: dict[str, Any], p_elec_avg: Any, p_mech_avg: Any,
                  regularization: Any, tracking: Any, fict_penalty: Any) -> Any:
        """Scaled objective: weighted average powers, regularization and homotopy terms.

        ``weights`` holds the symbols of :data:`PARAM_NAMES` (but the wind).
        """
        return ((weights["w_elec"] * p_elec_avg + weights["w_mech"] * p_mech_avg)
                / self.scales.power_w
                + weights["w_reg"] * regularization
                + weights["w_track"] * tracking
                + weights["w_fict"] * fict_penalty)

    # ---------------------------------------------------------------- bounds
    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the state [SI] (position bounds are never active:
        they only keep the solver in range)."""
        lim = self.limits
        l_lo, l_hi = lim.tether_length_bounds_m
        reach = 4.0 * l_hi
        z_top = lim.min_altitude_m - self.dae.wind.origin_altitude_m  # r_z <= -(clearance)
        surf, spin = lim.surface_bound_deg * DEG, 6 * np.pi
        hi = {"r_x_m": reach, "r_y_m": reach, "r_z_m": -z_top, "v_x_m_s": 200, "v_y_m_s": 200,
              "v_z_m_s": 200, "omega_x_rad_s": spin, "omega_y_rad_s": spin,
              "omega_z_rad_s": spin, "l_m": l_hi, "dl_m_s": 100, "ddl_m_s2": 500,
              "aileron_rad": surf, "elevator_rad": surf, "rudder_rad": surf}
        lo = {name: -value for name, value in hi.items()}
        lo.update(r_z_m=-reach, l_m=l_lo)
        lower = np.array([-1.1 if n.startswith("dcm_") else lo[n] for n in km.STATE_NAMES])
        upper = np.array([1.1 if n.startswith("dcm_") else hi[n] for n in km.STATE_NAMES])
        return lower, upper

    def start_state_fixed(self) -> dict[int, float]:
        """State components fixed at t = 0 (the cycle's phase: ``r_y(0) = 0``) [SI]."""
        return {km.IDX["r_y_m"]: 0.0}

    def limited_state_bounds(self) -> dict[int, tuple[float, float]]:
        """State bounds that replace :meth:`state_bounds` when the drive limits apply [SI]."""
        kite = self.dae.kite
        dl_max = max_reel_speed_m_s(self.limits.max_speed_rpm / kite.gear_ratio,
                                    kite.r_winch_m)
        return {X_REEL_SPEED: (-dl_max, dl_max)}

    def algebraic_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of the algebraic variables [SI]: tension ``l nu >= 0``."""
        lo, hi = np.full(km.NZ, -np.inf), np.full(km.NZ, np.inf)
        lo[Z_NU] = 0.0
        return lo, hi

    def control_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of the controls [SI]: tether jerk and control-surface rates."""
        rate = self.limits.surface_rate_bound_rad_s
        lo, hi = np.full(km.NU, -rate), np.full(km.NU, rate)
        lo[U_JERK], hi[U_JERK] = -5000.0, 5000.0
        return lo, hi

    def period_bounds(self) -> tuple[float, float]:
        """Bounds of the free period [s]."""
        return self.limits.period_bounds_s
