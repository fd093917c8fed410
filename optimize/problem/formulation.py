"""The kite's periodic pumping-cycle OCP in continuous time (paper section IV, eq. 5).

What is optimized and subject to what, independent of how it is transcribed
(:mod:`optimize.problem.transcription`): the kite DAE, its path constraints at a
point of the cycle, the conditions at the cycle's start and between its start and
end (invariants, periodicity), the cycle averages and the objective, and the
bounds of the variables. Everything is returned scaled (each expression divided
by its typical size, :mod:`optimize.problem.scaling`). :class:`Formulation`
implements :class:`optimize.problem.interface.CycleFormulation`.

A new path constraint is one more :class:`optimize.problem.interface.Row` in
:meth:`Formulation.point`; the transcriptions place it at every collocation point
and find it by its name.
"""

from __future__ import annotations

import functools
import operator
from dataclasses import dataclass, field
from typing import Any

import casadi as ca
import numpy as np

from kernel.units import RPM_PER_RAD_S
from optimize.model.drivetrain import (
    DriveModel,
    Drivetrain,
    max_reel_speed_m_s,
    motor_torque_nm,
)
from optimize.model.envelope import EnvelopeTable, constant_power_w
from optimize.model.kite_model import STATES, KiteDae
from optimize.model.thermal import RANGE_C as THERMAL_RANGE_C
from optimize.model.thermal import SCALE_K, STATE, WindingThermal
from optimize.problem.interface import Point, Row, weight_param
from optimize.problem.options import Discretization, Limits
from optimize.problem.scaling import Scales

# ---- named parts of the kite's state, algebraic and control vectors
#: body-to-world DCM entries (column-major) in the state
X_DCM = slice(STATES.index("dcm_11"), STATES.index("dcm_33") + 1)
#: tether length, reel-out speed and acceleration in the state
X_LENGTH, X_REEL_SPEED = STATES.index("l_m"), STATES.index("dl_m_s")
X_REEL_ACCELERATION = STATES.index("ddl_m_s2")
#: the reel acceleration's bound when the winch states none: keeps the solver in range
SOLVER_REEL_ACCELERATION_M_S2 = 500.0
#: the reel jerk's bound (the control's) when the winch states none: the solver's range
SOLVER_REEL_JERK_M_S3 = 5000.0

#: the cycle averages of a point: electrical and mechanical power drawn [W], and the
#: squared motor torque over its scale (the RMS-torque rating's integrand)
AVERAGES = ("p_elec_w", "p_mech_w", "torque_sq")
#: the averages a scenario's objective can weight (``optimize.kinds.Objective.average``)
OBJECTIVE_AVERAGES = ("p_elec_w", "p_mech_w")

DEG = np.pi / 180


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
    thermal : WindingThermal, optional
        The winding's thermal model and limit: ``dae`` then carries the winding
        temperature (:func:`optimize.model.thermal.with_winding_temperature`), the
        copper losses follow it and its limit replaces the RMS-torque row.
    """

    dae: KiteDae
    drive_model: DriveModel
    limits: Limits
    discretization: Discretization
    scales: Scales
    thermal: WindingThermal | None = None
    averages: tuple[str, ...] = field(default=AVERAGES, init=False)
    objective_averages: tuple[str, ...] = field(default=OBJECTIVE_AVERAGES, init=False)

    @property
    def constrained_averages(self) -> tuple[str, ...]:
        """The squared torque when the drive has an RMS-torque rating (and no thermal one)."""
        return () if self._rms_rating() is None else ("torque_sq",)

    def _rms_rating(self) -> float | None:
        return self.limits.max_rms_torque_nm if self.thermal is None else None

    @property
    def objective_scale(self) -> float:
        """Power scale [W] of the objective's average powers."""
        return self.scales.power_w

    # ---------------------------------------------------------------- dynamics
    def ode(self, x: Any, u: Any, z: Any) -> Any:
        """Explicit part of the DAE ``xdot = f(x, u, z)`` (physical units)."""
        return self.dae.ode(x, u, z)

    def tension_n(self, x: Any, z: Any) -> Any:
        """Tether tension [N]."""
        return x[X_LENGTH] * z[self.dae.algebraic.index("nu_n_per_m")]

    def p_elec_w(self, speed_rpm: Any, torque_nm: Any, theta_c: Any = None) -> Any:
        """Electrical power drawn [W] (CasADi): the power model, its copper loss at the
        winding temperature ``theta_c`` [degC] when the formulation has a thermal model."""
        p = self.drive_model.casadi_p_elec_w(speed_rpm, torque_nm)
        if self.thermal is None:
            return p
        return p + self.thermal.copper_drift_w(torque_nm, theta_c)

    def heat_w(self, x: Any, z: Any, theta_c: Any) -> Any:
        """The drive's losses [W] at a point (the kite's state ``x``, which may carry more
        after it), the heat of the winding's thermal model."""
        drivetrain = self.drivetrain
        tension = self.tension_n(x, z)
        dl, ddl = x[X_REEL_SPEED], x[X_REEL_ACCELERATION]
        torque = drivetrain.shaft_torque_nm(tension, ddl)
        return (self.p_elec_w(drivetrain.speed_rpm(dl), torque, theta_c)
                - drivetrain.shaft_power_w(tension, dl, ddl))

    def heat_function(self) -> ca.Function:
        """``(x, z, theta_c) -> heat [W]`` on this formulation's state and algebraic
        variables (:meth:`heat_w`)."""
        x = ca.SX.sym("x", self.dae.states.size)
        z = ca.SX.sym("z", self.dae.algebraic.size)
        theta = ca.SX.sym("theta_c")
        return ca.Function("heat_w", [x, z, theta], [self.heat_w(x, z, theta)])

    def winding_temperature_c(self, x: Any) -> Any:
        """The winding temperature [degC] of the state (None without a thermal model)."""
        return None if self.thermal is None else x[self.dae.states.index(STATE)]

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

    @property
    def drivetrain(self) -> Drivetrain:
        """Drum, gearbox and rotor between the tether and the drive."""
        return Drivetrain.of(self.dae.kite)

    def torque_rows(self, tension: Any, torque: Any) -> list[Row]:
        """Rows on the drive's shaft torque ``torque`` [N m] and the tether's.

        Massless drivetrain: one row, the shaft torque (the tether's) below the kite's
        tether-force limit in every kind and below the drive's torque limit in the
        ``*-lim`` kinds. With inertia the shaft torque also goes negative (braking a
        reel-in), so the drive's limit bounds it both ways, and the tether-force limit
        has a row of its own on the tether torque.
        """
        sc, lim = self.scales, self.limits
        _, torque_top = self.kite_limits()
        if self.drivetrain.inertia_kg_m2 == 0:
            return [Row("torque", torque / sc.torque_nm, -np.inf, torque_top / sc.torque_nm,
                        limited=(-np.inf, min(lim.max_torque_nm, torque_top) / sc.torque_nm))]
        top = lim.max_torque_nm / sc.torque_nm
        rows = [Row("torque", torque / sc.torque_nm, -np.inf, np.inf, limited=(-top, top))]
        if np.isfinite(torque_top):
            rows.append(Row("tether_force", self.drivetrain.tether_torque_nm(tension)
                            / sc.torque_nm, -np.inf, torque_top / sc.torque_nm))
        return rows

    def envelope_rows(self, speed_rpm: Any, torque: Any) -> list[Row]:
        """The drive's torque-speed envelope in the ``*-lim`` kinds (none without one):
        ``|T w| <= T_max w_base`` above a base speed, or the table's largest torque."""
        lim, sc = self.limits, self.scales
        if lim.base_speed_rpm is not None:
            power = constant_power_w(lim.max_torque_nm, lim.base_speed_rpm)
            return [Row("envelope", torque * speed_rpm / RPM_PER_RAD_S / power, -np.inf,
                        np.inf, limited=(-1.0, 1.0))]
        if lim.envelope_speed_rpm is None:
            return []
        top = EnvelopeTable(lim.envelope_speed_rpm, lim.envelope_torque_nm
                            ).smooth_torque_nm(speed_rpm)
        return [Row("envelope", ca.vertcat(torque - top, -torque - top) / sc.torque_nm,
                    -np.inf, np.inf, limited=(-np.inf, 0.0))]

    # ---------------------------------------------------------------- one point
    def point(self, x: Any, u: Any, z: Any, fict: Any, wind: Any) -> Point:
        """Rows and integrands at one collocation point (physical ``x, u, z, fict``)."""
        lim, sc = self.limits, self.scales
        drivetrain = self.drivetrain
        out = dict(zip(self.dae.outputs.name_out(), self.dae.outputs(x, u, z, wind),
                       strict=True))
        tension = self.tension_n(x, z)
        dl, ddl = x[X_REEL_SPEED], x[X_REEL_ACCELERATION]
        speed = drivetrain.speed_rpm(dl)
        torque = drivetrain.shaft_torque_nm(tension, ddl)
        theta = self.winding_temperature_c(x)
        p_elec = self.p_elec_w(speed, torque, theta)
        v_sc = sc.airspeed_m_s
        v_top, _ = self.kite_limits()
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
            *self.torque_rows(tension, torque),
            *self.envelope_rows(speed, torque),
        ]
        if self.thermal is not None:
            rows.append(Row("winding_temperature", theta / SCALE_K, -np.inf, np.inf,
                            limited=(-np.inf, self.thermal.max_c / SCALE_K)))
        if lim.max_p_elec_w is not None:
            p_lim = lim.max_p_elec_w / sc.power_w
            rows.append(Row("p_elec", p_elec / sc.power_w, -np.inf, np.inf,
                            limited=(-p_lim, p_lim)))
        averages = {"p_elec_w": p_elec, "p_mech_w": drivetrain.shaft_power_w(tension, dl, ddl),
                    "torque_sq": (torque / sc.torque_nm) ** 2}
        return Point(rows=rows, averages=averages,
                     fict_sq=ca.sumsqr(fict / ca.DM(sc.fictitious)))

    def trajectory_outputs(self, x: np.ndarray, u: np.ndarray, z: np.ndarray,
                           wind_speed_m_s: float) -> dict[str, np.ndarray]:
        """Drive and flight quantities at points (columns of ``x, u, z``) [SI, rpm, deg]:
        motor speed, the drive's shaft torque and the tether's at the motor, tension, shaft
        and electrical power, altitude, airspeed, angles of attack and sideslip, local
        wind, line angle, invariants."""
        drivetrain = self.drivetrain
        outputs = self.dae.outputs.map(x.shape[1])(x, u, z, wind_speed_m_s)
        out = {name: np.asarray(val).ravel()
               for name, val in zip(self.dae.outputs.name_out(), outputs, strict=True)}
        dl, ddl = x[X_REEL_SPEED], x[X_REEL_ACCELERATION]
        tension = x[X_LENGTH] * z[self.dae.algebraic.index("nu_n_per_m")]
        speed_rpm = drivetrain.speed_rpm(dl)
        torque_nm = drivetrain.shaft_torque_nm(tension, ddl)
        p_elec = np.asarray(self.drive_model.p_elec_w(speed_rpm, torque_nm))
        if self.thermal is not None:
            p_elec = p_elec + self.thermal.copper_drift_w(
                torque_nm, x[self.dae.states.index(STATE)])
        return {
            "speed_rpm": speed_rpm, "torque_nm": torque_nm,
            "tether_torque_nm": drivetrain.tether_torque_nm(tension), "tension_n": tension,
            "p_mech_w": drivetrain.shaft_power_w(tension, dl, ddl),
            "p_elec_w": p_elec,
            "altitude_m": out["altitude_m"], "airspeed_m_s": out["airspeed_m_s"],
            "alpha_deg": np.degrees(out["alpha_rad"]), "beta_deg": np.degrees(out["beta_rad"]),
            "wind_m_s": out["wind_m_s"],
            "line_angle_deg": np.degrees(np.arccos(np.clip(out["cos_line_angle"], -1, 1))),
            "c_m2": out["c_m2"], "cdot_m2_s": out["cdot_m2_s"],
        }

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
        per = self.dae.states.indices(self.dae.periodic)
        dcm0 = ca.reshape(x0[X_DCM], 3, 3)
        rel = ca.mtimes(dcm0.T, ca.reshape(x_end[X_DCM], 3, 3))
        return [
            Row("periodic", (x_end[per] - x0[per]) * ca.DM(1.0 / self.scales.state[per])),
            Row("periodic", ca.vertcat(rel[0, 1], rel[0, 2], rel[1, 2])),
        ]

    def average_rows(self, averages: dict[str, Any]) -> list[Row]:
        """Rows on cycle averages: the drive's RMS torque rating, when it has one and no
        thermal rating."""
        rms = self._rms_rating()
        if rms is None:
            return []
        return [Row("rms_torque", averages["torque_sq"], -np.inf, np.inf,
                    limited=(-np.inf, (rms / self.scales.torque_nm) ** 2))]

    def objective(self, weights: dict[str, Any], averages: dict[str, Any],
                  regularization: Any, tracking: Any, fict_penalty: Any) -> Any:
        """Scaled objective: weighted average powers, regularization and homotopy terms.

        ``weights`` holds the NLP's weight parameters by name
        (:func:`optimize.problem.interface.param_names`).
        """
        terms = [weights[weight_param(a)] * averages[a] for a in self.objective_averages]
        return (functools.reduce(operator.add, terms) / self.objective_scale
                + weights["w_reg"] * regularization
                + weights["w_track"] * tracking
                + weights["w_fict"] * fict_penalty)

    # ---------------------------------------------------------------- bounds
    def state_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper bounds of the state [SI] (position bounds are never active:
        they only keep the solver in range; the reel acceleration's is the winch's limit
        when the system states one, in every kind)."""
        lim = self.limits
        l_lo, l_hi = lim.tether_length_bounds_m
        reach = 4.0 * l_hi
        z_top = lim.min_altitude_m - self.dae.wind.origin_altitude_m  # r_z <= -(clearance)
        surf, spin = lim.surface_bound_deg * DEG, 6 * np.pi
        hi = {"r_x_m": reach, "r_y_m": reach, "r_z_m": -z_top, "v_x_m_s": 200, "v_y_m_s": 200,
              "v_z_m_s": 200, "omega_x_rad_s": spin, "omega_y_rad_s": spin,
              "omega_z_rad_s": spin, "l_m": l_hi, "dl_m_s": 100,
              "ddl_m_s2": lim.max_reel_acceleration_m_s2 or SOLVER_REEL_ACCELERATION_M_S2,
              "aileron_rad": surf, "elevator_rad": surf, "rudder_rad": surf}
        lo = {name: -value for name, value in hi.items()}
        lo.update(r_z_m=-reach, l_m=l_lo)
        for name in () if self.thermal is None else self.thermal.states:
            lo[name], hi[name] = THERMAL_RANGE_C  # the solver's range: no winding limit here
        names = self.dae.states.names
        lower = np.array([-1.1 if n.startswith("dcm_") else lo[n] for n in names])
        upper = np.array([1.1 if n.startswith("dcm_") else hi[n] for n in names])
        return lower, upper

    def start_state_fixed(self) -> dict[int, float]:
        """State components fixed at t = 0 (the cycle's phase: ``r_y(0) = 0``) [SI]."""
        return {self.dae.states.index("r_y_m"): 0.0}

    def limited_state_bounds(self) -> dict[int, tuple[float, float]]:
        """State bounds that replace :meth:`state_bounds` when the drive limits apply [SI]."""
        kite = self.dae.kite
        dl_max = max_reel_speed_m_s(self.limits.max_speed_rpm / kite.gear_ratio,
                                    kite.r_winch_m)
        return {X_REEL_SPEED: (-dl_max, dl_max)}

    def algebraic_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of the algebraic variables [SI]: tension ``l nu >= 0``."""
        alg = self.dae.algebraic
        lo, hi = np.full(alg.size, -np.inf), np.full(alg.size, np.inf)
        lo[alg.index("nu_n_per_m")] = 0.0
        return lo, hi

    def control_bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Bounds of the controls [SI]: tether jerk (the winch's limit when the system
        states one, in every kind) and control-surface rates."""
        rate = self.limits.surface_rate_bound_rad_s
        controls = self.dae.controls
        lo, hi = np.full(controls.size, -rate), np.full(controls.size, rate)
        jerk = controls.index("dddl_m_s3")
        limit = self.limits.max_reel_jerk_m_s3 or SOLVER_REEL_JERK_M_S3
        lo[jerk], hi[jerk] = -limit, limit
        return lo, hi

    def period_bounds(self) -> tuple[float, float]:
        """Bounds of the free period [s]."""
        return self.limits.period_bounds_s
