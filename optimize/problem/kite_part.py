"""The tethered kite as a part of the cycle OCP (paper eqs. 6-8, section IV).

Its variables are the kite DAE's (:mod:`optimize.model.kite_model`); its quantities the
DAE's outputs at a point (tension, airspeed, angles, altitude, local wind, invariants);
its rows the Newton-Euler residual, the flight envelope (airspeed, angle of attack,
sideslip, line angle), the invariants at the start and the DCM's closing rotation; its
bounds the system's reach, tether length, ground clearance and the winch's acceleration
and jerk limits; its start the circular loop (:func:`optimize.problem.guess.circular_loop`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from kernel.names import WIND_SPEED
from kernel.sections import bound_values
from optimize.model.aero import SURFACES
from optimize.model.kite_model import KiteDae
from optimize.problem.guess import LoopGuess, circular_loop
from optimize.problem.interface import Row
from optimize.problem.options import SOLVER_BODY_RATE_RAD_S, SOLVER_REEL_SPEED_M_S
from optimize.problem.part import Part, StartPoint, near
from optimize.problem.scaling import Scales

#: the reel acceleration's bound when the winch states none: keeps the solver in range
SOLVER_REEL_ACCELERATION_M_S2 = 500.0
#: the reel jerk's bound (the control's) when the winch states none: the solver's range
SOLVER_REEL_JERK_M_S3 = 5000.0
#: forces [N] (world NED frame, on the CG) and moments [N m] (body frame) other parts put
#: on the kite: quantities of these names enter its Newton-Euler rows as the homotopy's
#: fictitious forces do (a part adds its own to what the parts before it put there)
EXTERNAL = ("f_ext_x_n", "f_ext_y_n", "f_ext_z_n", "m_ext_x_nm", "m_ext_y_nm", "m_ext_z_nm")
#: the CG position's components (not periodic: the downwind position is free)
POSITION_STATES = ("r_x_m", "r_y_m", "r_z_m")

DEG = np.pi / 180


def _vector(q: Mapping[str, Any], names: tuple[str, ...]) -> Any:
    return ca.vertcat(*[q[n] for n in names])


def body_rate_limit_rad_s(bounds: Any) -> float | None:
    """The system's bound of each body rate [rad/s] (its ``[bounds]`` section), or None."""
    top = bound_values(bounds)["body_rate_limit"]
    return None if top is None else top * math.pi / 180


def reel_speed_range_m_s(winch: Any) -> tuple[float, float]:
    """The reel speed ``l'`` range of every kind [m/s]: the winch's limits (its ``[winch]``
    section), the solver's range of :data:`SOLVER_REEL_SPEED_M_S` where unstated."""
    values = bound_values(winch)
    return (-(values["reel_in_speed_limit"] or SOLVER_REEL_SPEED_M_S),
            values["reel_out_speed_limit"] or SOLVER_REEL_SPEED_M_S)


@dataclass(frozen=True)
class KitePart(Part):
    """The kite (a :class:`optimize.problem.part.Part`).

    Parameters
    ----------
    dae : KiteDae
    system : optimize.system.system.System
        Its inputs: the system's ``[aero]``, ``[winch]`` and ``[bounds]`` sections (the
        angle ranges, the reel limits, the flight envelope and the search ranges).
    scales_of : Scales
        The system's magnitudes (:func:`optimize.problem.scaling.system_scales`).
    loop : LoopGuess
        The start loop.
    """

    dae: KiteDae
    system: Any
    scales_of: Scales
    loop: LoopGuess
    name: str = "kite"
    output_columns: tuple[str, ...] = ("altitude_m", "airspeed_m_s", "alpha_deg", "beta_deg",
                                       "wind_m_s", "line_angle_deg", "c_m2", "cdot_m2_s")

    states = property(lambda self: self.dae.states, doc="The kite DAE's states.")
    controls = property(lambda self: self.dae.controls, doc="The kite DAE's controls.")
    algebraic = property(lambda self: self.dae.algebraic, doc="Its algebraic variables.")
    fictitious = property(lambda self: self.dae.fictitious, doc="Its fictitious forces.")
    periodic = property(lambda self: self.dae.periodic, doc="Its periodic states.")
    parameters = property(lambda self: self.dae.parameters, doc="Its reference wind.")

    def _xuz(self, q: Mapping[str, Any]) -> tuple[Any, Any, Any]:
        return (_vector(q, self.states.names), _vector(q, self.controls.names),
                _vector(q, self.algebraic.names))

    def quantities(self, q: Mapping[str, Any]) -> dict[str, Any]:
        """The DAE's outputs (``airspeed_m_s``, ``alpha_rad``, ``tension_n``, ...)."""
        x, u, z = self._xuz(q)
        out = self.dae.outputs(x, u, z, q[WIND_SPEED])
        return dict(zip(self.dae.outputs.name_out(), out, strict=True))

    def rates(self, q: Mapping[str, Any]) -> list[Any]:
        """The kinematics (paper eq. 7)."""
        return [self.dae.ode(*self._xuz(q))]

    def residual(self, q: Mapping[str, Any]) -> list[Any]:
        """Newton-Euler and ``d2c/dt2`` over their scales, with the forces and moments
        other parts put on the kite (:data:`EXTERNAL`)."""
        x, u, z = self._xuz(q)
        fict = _vector(q, self.fictitious.names)
        if any(name in q for name in EXTERNAL):
            fict = fict + ca.vertcat(*[q.get(name, 0) for name in EXTERNAL])
        return [self.dae.alg(x, u, z, q[WIND_SPEED], fict) * ca.DM(1.0 / self.scales_of.residual)]

    @property
    def limits(self) -> dict[str, Any]:
        """The system's bounds by the names ``active_bounds`` reports them by
        (:meth:`optimize.system.system.System.bound_values`)."""
        return self.system.bound_values()

    def period_bounds_s(self) -> tuple[float, float]:
        """The free period's search range [s]."""
        lim = self.limits
        return lim["period_min"], lim["period_max"]

    def body_rate_bound_rad_s(self) -> float:
        """The bound of each body rate of every kind [rad/s]: the system's, the solver's
        range of :data:`SOLVER_BODY_RATE_RAD_S` where unstated."""
        top = body_rate_limit_rad_s(self.system.bounds)
        return SOLVER_BODY_RATE_RAD_S if top is None else top

    def rows(self, q: Mapping[str, Any]) -> list[Row]:
        """Airspeed (the kite's limit in every kind), angle of attack, sideslip and line
        angle."""
        lim, aero, v_sc = self.limits, self.system.aero, self.scales_of.airspeed_m_s
        v_top = np.inf if lim["airspeed_max"] is None else lim["airspeed_max"]
        return [
            Row("airspeed", q["airspeed_m_s"] / v_sc, lim["airspeed_min"] / v_sc,
                v_top / v_sc),
            Row("alpha", q["alpha_rad"] / (10 * DEG), aero.alpha_min_deg / 10,
                aero.alpha_max_deg / 10),
            Row("beta", q["beta_rad"] / (10 * DEG), aero.beta_min_deg / 10,
                aero.beta_max_deg / 10),
            Row("line_angle", q["cos_line_angle"], np.cos(lim["line_angle_limit"] * DEG),
                np.inf),
        ]

    def outputs(self, q: Mapping[str, Any]) -> dict[str, Any]:
        """Altitude, airspeed, angles [deg], local wind, line angle [deg], invariants."""
        to_deg = 180.0 / np.pi
        return {
            "altitude_m": q["altitude_m"], "airspeed_m_s": q["airspeed_m_s"],
            "alpha_deg": q["alpha_rad"] * to_deg, "beta_deg": q["beta_rad"] * to_deg,
            "wind_m_s": q["wind_m_s"],
            "line_angle_deg": ca.acos(ca.fmin(ca.fmax(q["cos_line_angle"], -1), 1)) * to_deg,
            "c_m2": q["c_m2"], "cdot_m2_s": q["cdot_m2_s"],
        }

    def bounds(self) -> dict[str, tuple[float, float]]:
        """Position bounds only keep the solver in range; the tether length's, the
        ground's, the body rates' and the winch's reel speed, acceleration and jerk
        limits are the system's; the tension ``l nu >= 0``; the control-surface
        deflections and rates."""
        lim = self.limits
        l_lo, l_hi = lim["tether_length_min"], lim["tether_length_max"]
        reach = 4.0 * l_hi
        z_top = lim["ground_clearance"] - self.dae.wind.origin_altitude_m  # r_z <= -(clearance)
        rate = self.system.bounds.surface_rate_max_rad_s
        spin = self.body_rate_bound_rad_s()
        ddl = lim["reel_acceleration_limit"] or SOLVER_REEL_ACCELERATION_M_S2
        jerk = lim["reel_jerk_limit"] or SOLVER_REEL_JERK_M_S3
        sym = {"r_x_m": reach, "r_y_m": reach, "v_x_m_s": 200, "v_y_m_s": 200,
               "v_z_m_s": 200, "omega_x_rad_s": spin, "omega_y_rad_s": spin,
               "omega_z_rad_s": spin, "ddl_m_s2": ddl, "dddl_m_s3": jerk,
               **{f"{s}_rad": bound * DEG
                  for s, bound in zip(SURFACES, lim["surface_limit"], strict=True)},
               "daileron_rad_s": rate, "delevator_rad_s": rate, "drudder_rad_s": rate}
        out = {name: (-top, top) for name, top in sym.items()}
        out.update({n: (-1.1, 1.1) for n in self.states.names if n.startswith("dcm_")})
        out.update(r_z_m=(-reach, -z_top), l_m=(l_lo, l_hi), nu_n_per_m=(0.0, np.inf),
                   dl_m_s=reel_speed_range_m_s(self.system.winch))
        return out

    def scales(self) -> dict[str, float]:
        """Magnitudes from the start loop's length, speed and rate, the weight, the
        surface bounds (:func:`optimize.problem.scaling.system_scales`)."""
        sc, lim = self.scales_of, self.limits
        rate_bound = self.system.bounds.surface_rate_max_rad_s
        length, speed, rate = sc.length_m, sc.speed_m_s, sc.rate_rad_s
        kite = self.dae.kite
        return {
            **{f"r_{a}_m": 1.25 * length for a in "xyz"},
            **{f"v_{a}_m_s": 1.15 * speed for a in "xyz"},
            **{f"dcm_{i}{j}": 1.0 for i in (1, 2, 3) for j in (1, 2, 3)},
            **{f"omega_{a}_rad_s": 2.4 * rate for a in "xyz"},
            "l_m": 1.25 * length, "dl_m_s": 0.4 * speed, "ddl_m_s2": 0.9 * speed * rate,
            **{f"{s}_rad": 1.15 * (bound * DEG)
               for s, bound in zip(SURFACES, lim["surface_limit"], strict=True)},
            "dddl_m_s3": 2.4 * speed * rate**2,
            **{f"d{s}_rad_s": rate_bound for s in SURFACES},
            **{f"a_{a}_m_s2": 1.5 * speed * rate for a in "xyz"},
            **{f"domega_{a}_rad_s2": 6.3 * rate**2 for a in "xyz"},
            "nu_n_per_m": 11.0 * kite.mass_kg * kite.g_m_s2 / length,
            **{f"f_fict_{a}_n": sc.force_n for a in "xyz"},
            **{f"m_fict_{a}_nm": sc.moment_nm for a in "xyz"},
        }

    def active_bounds(self, traj: Any, drive_limits: bool) -> list[str]:
        """Tether length, ground clearance, airspeed, angle of attack, sideslip, the
        winch's acceleration, jerk and reel-speed limits, the body rates, the tension floor,
        the line angle and the control-surface deflections (the kite's own, in every kind).
        An angle is on its bound within :data:`~optimize.problem.part.ACTIVE_RTOL` of its
        range (a bound of 0 deg has no relative tolerance of its own)."""
        lim = self.limits
        a_lo, a_hi = lim["alpha_min"], lim["alpha_max"]
        b_lo, b_hi = lim["beta_min"], lim["beta_max"]
        rates = np.degrees(np.abs(traj[["omega_x_rad_s", "omega_y_rad_s",
                                        "omega_z_rad_s"]].to_numpy()))
        surfaces = np.degrees(np.abs(traj[[f"{s}_rad" for s in SURFACES]].to_numpy()))
        checks = (("tether_length_min", traj["l_m"], lim["tether_length_min"]),
                  ("tether_length_max", traj["l_m"], lim["tether_length_max"]),
                  ("ground_clearance", traj["altitude_m"], lim["ground_clearance"]),
                  ("airspeed_min", traj["airspeed_m_s"], lim["airspeed_min"]),
                  ("airspeed_max", traj["airspeed_m_s"], lim["airspeed_max"]),
                  ("alpha_min", (a_hi - traj["alpha_deg"]) / (a_hi - a_lo), 1.0),
                  ("alpha_max", (traj["alpha_deg"] - a_lo) / (a_hi - a_lo), 1.0),
                  ("beta_min", (b_hi - traj["beta_deg"]) / (b_hi - b_lo), 1.0),
                  ("beta_max", (traj["beta_deg"] - b_lo) / (b_hi - b_lo), 1.0),
                  ("reel_acceleration_limit", np.abs(traj["ddl_m_s2"]),
                   lim["reel_acceleration_limit"]),
                  ("reel_jerk_limit", np.abs(traj["dddl_m_s3"]), lim["reel_jerk_limit"]),
                  ("reel_out_speed_limit", traj["dl_m_s"], lim["reel_out_speed_limit"]),
                  ("reel_in_speed_limit", -traj["dl_m_s"], lim["reel_in_speed_limit"]),
                  ("body_rate_limit", rates, lim["body_rate_limit"]),
                  ("tension_min", traj["tension_n"], lim["tension_min"]),
                  ("line_angle_limit", traj["line_angle_deg"], lim["line_angle_limit"]),
                  ("surface_limit", surfaces / np.asarray(lim["surface_limit"]), 1.0))
        return [name for name, value, bound in checks if near(value, bound)]

    def start_rows(self, q0: Mapping[str, Any]) -> list[Row]:
        """Invariants at t = 0: tether constraint, its rate, an orthonormal DCM."""
        sc = self.scales_of
        c0, cdot0, orth0 = self.dae.invariants(_vector(q0, self.states.names))
        return [
            Row("invariant_c", c0 / sc.c_m2),
            Row("invariant_cdot", cdot0 / sc.cdot_m2_s),
            Row("orthonormal", ca.vertcat(*[orth0[a, b] for a in range(3) for b in range(a, 3)])),
        ]

    def periodicity_rows(self, q0: Mapping[str, Any], q_end: Mapping[str, Any]) -> list[Row]:
        """The DCM's relative rotation over the cycle is the identity."""
        dcm = [n for n in self.states.names if n.startswith("dcm_")]
        dcm0 = ca.reshape(_vector(q0, dcm), 3, 3)
        rel = ca.mtimes(dcm0.T, ca.reshape(_vector(q_end, dcm), 3, 3))
        return [Row("periodic", ca.vertcat(rel[0, 1], rel[0, 2], rel[1, 2]))]

    def start_fixed(self) -> dict[str, float]:
        """The cycle's phase: ``r_y(0) = 0``."""
        return {"r_y_m": 0.0}

    def guess(self, start: StartPoint) -> dict[str, np.ndarray]:
        """The circular loop (:func:`optimize.problem.guess.circular_loop`) at its own
        period, with the fictitious forces that make it a solution."""
        x, z, fict = circular_loop(self.dae, self.loop, start.grid_times_s,
                                   start.parameters[WIND_SPEED])
        out = dict(zip(self.states.names, x, strict=True))
        out.update(zip(self.algebraic.names, z[:, 1:], strict=True))
        out.update(zip(self.fictitious.names, fict[:, 1:], strict=True))
        return out
