"""Periodic pumping-cycle optimal control problem (paper section IV, eq. 5; REFERENCE.md §3).

Direct Radau collocation of the implicit kite DAE with a free period. The NLP
is built once per (options, drive model) and is solved for any scenario by
changing only NLP parameters (wind speed, objective weights, homotopy
weights, reference trajectory) and variable/constraint bounds (drive limits,
fixed period, fictitious forces switched off). Everything is scaled: each
decision variable is stored divided by a typical magnitude, each residual row
is divided by its typical size.

Decision vector (scaled), in this order: one copy of the period ``T`` per
interval (tied by equality rows, so no variable couples every interval); states at the
``N d + 1`` grid points (interval starts and the Radau points; the last Radau
point of an interval is the start of the next); algebraic variables at the
``N d`` Radau points; one control per interval; fictitious forces/moments at
the ``N d`` Radau points (homotopy only; fixed at zero otherwise).
"""

from __future__ import annotations

import logging
import os
import time
from dataclasses import dataclass, field
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
from optimize.problem.collocation import Collocation, radau
from optimize.problem.guess import LoopGuess, start_loop
from optimize.problem.scaling import Scales, system_scales

log = logging.getLogger(__name__)


def _single_threaded_blas() -> None:
    """Let casadi's bundled OpenBLAS (MUMPS' BLAS) run one thread, unless the user chose.

    OpenBLAS reads ``OPENBLAS_NUM_THREADS`` when it loads, which casadi does on the
    first IPOPT solver with MUMPS. On this NLP (about 6,100 variables) a second BLAS
    thread only spins, and the sweep already runs one solver per core. Measured with
    ``benchmarks/optimize_sweep_benchmark.py`` on 2 idle cores: the 2-worker sweep went
    from 111 s to 91 s, the median warm solve from 6.5 s to 4.9 s, and system time
    from 180 s to 27 s.
    """
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

#: periodic state components (REFERENCE.md §3)
PERIODIC_STATES = (
    "r_y_m", "r_z_m", "v_y_m_s", "v_z_m_s", "omega_x_rad_s", "omega_y_rad_s",
    "omega_z_rad_s", "l_m", "dl_m_s", "ddl_m_s2", "aileron_rad", "elevator_rad", "rudder_rad",
)
#: NLP parameter layout (before the reference trajectory)
PARAM_NAMES = ("wind_ref_m_s", "w_elec", "w_mech", "w_reg", "w_track", "w_fict")


#: most collocation intervals per period: the default is 40 and the trust check's mesh
#: refinement doubles it; 400 already means ~10^5 NLP variables and minutes per solve
MAX_INTERVALS = 400


@dataclass(frozen=True)
class OcpOptions:
    """Discretization, physical limits and solver settings of the OCP.

    Parameters
    ----------
    n_intervals : int
        Number of collocation intervals over one period.
    degree : int
        Radau collocation degree.
    tol : float
        IPOPT convergence tolerance (scaled problem).
    acceptable_tol : float
        IPOPT acceptable tolerance.
    max_iter : int
        IPOPT iteration limit per solve.
    regularization_w : float
        Weight of the control regularization ``mean_k sum_i (u_i / sigma_i)^2``
        [W]. The default 0.1 W is the weight of the reference
        implementation (rawesome ``pumping_poweropt.py``: 0.1 (u/sigma)^2 in W).
    control_sigma : (float, float, float, float)
        Scales ``sigma`` of tether jerk [m/s^3] and aileron, elevator, rudder
        rates [rad/s]. Default (10, 1, 1, 1). The reference implementation
        used (10, 0.001, 0.8, 0.1), which practically freezes the aileron; at
        N = 40 and 7 m/s that reproduces issue 4's prototype table to the watt
        (-1528 W / -48 W / 3.36 s mechanical) but leaves the 10 m/s periods
        further from the paper's (2.39 s and 4.2 s against 2.14 s and 3.89 s;
        the default gives 2.22 s and 3.82 s).
    period_bounds_s : (float, float)
        Bounds on the free period [s].
    tether_length_bounds_m : (float, float)
        Bounds on the tether length [m].
    min_altitude_m : float
        Lowest CG altitude above ground [m] (the system's ground clearance).
    max_speed_rpm, max_torque_nm : float
        Drive limits of the constrained scenarios at the motor shaft [rpm], [N m].
    max_p_elec_w : float or None
        Limit of the electrical power drawn or fed [W] in the constrained
        scenarios (rows only when set).
    nominal_power_w : float
        The drive's nominal power [W]: the objective's scale.
    max_rms_torque_nm : float or None
        Continuous rating of the drive: the RMS motor torque over the cycle,
        ``sqrt(mean_t T^2)``, at most this in the constrained scenarios [N m]
        (``max_torque_nm`` is then the short-time peak). ``None`` (default)
        leaves the row out of the NLP; it is the last constraint row, so a
        stored initial guess of the NLP without it still fits.
    min_airspeed_m_s : float
        Lower airspeed bound [m/s].
    max_airspeed_m_s : float or None
        Upper airspeed bound [m/s] of every scenario kind (the kite's limit);
        ``None`` leaves the airspeed unbounded above.
    max_tether_force_n : float or None
        Largest tether tension [N] of every scenario kind (the kite's and the
        line's limit, drive limits on or off); ``None``: no limit.
    alpha_bounds_deg, beta_bounds_deg : (float, float)
        Angle-of-attack and sideslip bounds [deg].
    max_line_angle_deg : float
        Largest angle between body z axis and tether [deg].
    surface_bound_deg : float
        Control-surface deflection bound [deg].
    surface_rate_bound_rad_s : float
        Control-surface rate bound [rad/s].
    warm_mu_init : float
        Initial barrier parameter of a warm-started solve.
    warm_bound_push : float
        IPOPT's ``warm_start_bound_push``, ``_bound_frac``, ``_slack_bound_push``,
        ``_slack_bound_frac`` and ``_mult_bound_push`` of a warm-started solve:
        how far (scaled units) the warm point and its bound multipliers are moved
        off their bounds. A neighbouring optimum has other active bounds; left
        within 1e-9 of them, the fraction-to-the-boundary rule cut the first
        steps to 1e-7..1e-2 of their length.
    stored_guess : bool
        Start a scenario with no neighbouring solution from the shipped initial
        guess (:mod:`optimize.solve.initial_guess`) when it fits, instead of the homotopy.
    linear_solver : str
        IPOPT linear solver.
    mumps_pivot_order : int
        MUMPS fill-reducing ordering (0 AMD, 2 AMF, 4 PORD, 6 QAMD, 7 automatic).
        AMD halves the cost of an iteration on this NLP against the automatic
        choice: at 40 intervals, warm solves took 2.2-3.7 s (0.07-0.12 s per
        iteration) against 4.9-5.7 s (0.16-0.20 s), over three runs of three
        transitions on 2 idle cores; cold start 26-30 s against 37 s.
    """

    n_intervals: int = 40
    degree: int = 4
    tol: float = 1e-6
    acceptable_tol: float = 1e-4
    max_iter: int = 1000
    regularization_w: float = 0.1
    control_sigma: tuple[float, float, float, float] = (10.0, 1.0, 1.0, 1.0)
    period_bounds_s: tuple[float, float] = (1.0, 20.0)
    tether_length_bounds_m: tuple[float, float] = (1.0, 500.0)
    min_altitude_m: float = 2.0
    max_speed_rpm: float = 1500.0
    max_torque_nm: float = 78.0
    max_p_elec_w: float | None = None
    nominal_power_w: float = 8200.0
    max_rms_torque_nm: float | None = None
    min_airspeed_m_s: float = 10.0
    max_airspeed_m_s: float | None = None
    max_tether_force_n: float | None = None
    alpha_bounds_deg: tuple[float, float] = (-4.5, 8.5)
    beta_bounds_deg: tuple[float, float] = (-9.0, 9.0)
    max_line_angle_deg: float = 65.0
    surface_bound_deg: float = 10.0
    surface_rate_bound_rad_s: float = 2.0
    warm_mu_init: float = 1e-4
    warm_bound_push: float = 1e-2
    stored_guess: bool = True
    linear_solver: str = "mumps"
    mumps_pivot_order: int = 0

    def __post_init__(self) -> None:
        if not 2 <= self.n_intervals <= MAX_INTERVALS:
            raise ValueError(f"n_intervals must be 2 to {MAX_INTERVALS}, got {self.n_intervals}")
        lo, hi = self.period_bounds_s
        if len(self.control_sigma) != 4 or min(self.control_sigma) <= 0:
            raise ValueError(f"control_sigma must be 4 positive scales, got {self.control_sigma}")
        if not 0 < lo < hi:
            raise ValueError(
                f"period_bounds_s must satisfy 0 < lo < hi, got {self.period_bounds_s}"
            )
        if self.max_rms_torque_nm is not None and not self.max_rms_torque_nm > 0:
            raise ValueError(f"max_rms_torque_nm must be > 0, got {self.max_rms_torque_nm}")
        for name in ("max_airspeed_m_s", "max_tether_force_n"):
            value = getattr(self, name)
            if value is not None and not value > 0:
                raise ValueError(f"{name} must be > 0, got {value}")
        if not 0 < self.warm_bound_push <= 0.5:  # IPOPT's range of warm_start_bound_frac
            raise ValueError(f"warm_bound_push must be in (0, 0.5], got {self.warm_bound_push}")


@dataclass
class Layout:
    """Index bookkeeping of the scaled decision and constraint vectors."""

    n_points: int  # grid points with states (N d + 1)
    n_coll: int  # Radau points (N d)
    i_period: np.ndarray  # (N,) one copy of the period per interval, all equal
    i_x: np.ndarray  # (NX, n_points) indices into w
    i_z: np.ndarray  # (NZ, n_coll)
    i_u: np.ndarray  # (NU, N)
    i_f: np.ndarray  # (NF, n_coll)
    scale_w: np.ndarray  # w_physical = scale_w * w_scaled
    n_w: int
    n_g: int
    g_torque: np.ndarray  # rows of the torque constraint
    g_p_elec: np.ndarray  # rows of the electrical power limit (empty without one)
    g_periodic: np.ndarray  # rows of the periodicity constraints (states and DCM)
    n_p: int
    i_p_ref: np.ndarray  # (NX, n_points) reference trajectory in p
    g_rms: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))  # RMS torque row


@dataclass(frozen=True)
class RawSolve:
    """Outcome of one IPOPT call: scaled primal/dual vectors and solver statistics."""

    w: np.ndarray
    lam_x: np.ndarray
    lam_g: np.ndarray
    objective: float
    status: str
    success: bool
    iterations: int
    wall_time_s: float
    cpu_time_s: float  # CPU time of this process during the call [s]


@dataclass
class Ocp:
    """A built OCP: the NLP, its layout, base bounds and IPOPT solvers (cold / warm).

    Build it with :func:`build_ocp`; solve it with :func:`optimize.solve.solve.solve`
    or :func:`optimize.solve.solve.cold_start`.
    """

    options: OcpOptions
    dae: KiteDae
    coll: Collocation
    layout: Layout
    nlp: dict
    lbw: np.ndarray
    ubw: np.ndarray
    lbg: np.ndarray
    ubg: np.ndarray
    build_time_s: float
    drive_model: DriveModel
    scales: Scales
    loop: LoopGuess
    system: Any = None
    _solvers: dict = field(default_factory=dict, repr=False)
    _g_fn: ca.Function | None = field(default=None, repr=False)
    _derivatives: dict | None = field(default=None, repr=False)

    def derivatives(self) -> dict[str, ca.Function]:
        """Objective gradient, constraint Jacobian and Lagrangian Hessian (built once).

        Handed to every IPOPT instance, so the warm-start solver costs about a
        second to create instead of repeating the symbolic differentiation.
        """
        if self._derivatives is None:
            t0 = time.perf_counter()
            x, p, f, g = self.nlp["x"], self.nlp["p"], self.nlp["f"], self.nlp["g"]
            lam_f = ca.SX.sym("lam_f")
            lam_g = ca.SX.sym("lam_g", g.shape[0])
            hess = ca.triu(ca.hessian(lam_f * f + ca.dot(lam_g, g), x)[0])
            self._derivatives = {
                "grad_f": ca.Function("nlp_grad_f", [x, p], [f, ca.gradient(f, x)],
                                      ["x", "p"], ["f", "grad_f_x"]),
                "jac_g": ca.Function("nlp_jac_g", [x, p], [g, ca.jacobian(g, x)],
                                     ["x", "p"], ["g", "jac_g_x"]),
                "hess_lag": ca.Function("nlp_hess_l", [x, p, lam_f, lam_g], [hess],
                                        ["x", "p", "lam_f", "lam_g"], ["hess_gamma_x_x"]),
            }
            log.debug("NLP derivatives in %.1f s", time.perf_counter() - t0)
        return self._derivatives

    def constraint_values(self, w_scaled: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Scaled constraint vector ``g(w, p)`` (for residual checks)."""
        if self._g_fn is None:
            self._g_fn = ca.Function("g", [self.nlp["x"], self.nlp["p"]], [self.nlp["g"]])
        return np.asarray(self._g_fn(w_scaled, p)).ravel()

    def run(
        self,
        w0: np.ndarray,
        p: np.ndarray,
        bounds: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
        warm: bool,
        lam_x0: np.ndarray | None = None,
        lam_g0: np.ndarray | None = None,
        bound_push: float | None = None,
    ) -> RawSolve:
        """One IPOPT solve from the scaled primal ``w0`` (and multipliers when ``warm``).

        ``bound_push`` overrides ``options.warm_bound_push`` of a warm solve.
        """
        solver = self.solver(warm, bound_push)
        args = {"x0": w0, "p": p, "lbx": bounds[0], "ubx": bounds[1], "lbg": bounds[2],
                "ubg": bounds[3]}
        if warm and lam_x0 is not None and lam_g0 is not None:
            args.update(lam_x0=lam_x0, lam_g0=lam_g0)
        t0, c0 = time.perf_counter(), time.process_time()
        sol = solver(**args)
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        stats = solver.stats()
        return RawSolve(
            w=np.asarray(sol["x"]).ravel(),
            lam_x=np.asarray(sol["lam_x"]).ravel(),
            lam_g=np.asarray(sol["lam_g"]).ravel(),
            objective=float(sol["f"]),
            status=str(stats["return_status"]),
            success=bool(stats["success"]),
            iterations=int(stats["iter_count"]),
            wall_time_s=wall,
            cpu_time_s=cpu,
        )

    def solver(self, warm: bool, bound_push: float | None = None) -> ca.Function:
        """IPOPT solver; ``warm`` selects warm-start options (created once, then cached).

        ``bound_push`` overrides ``options.warm_bound_push`` of a warm solver.
        """
        o = self.options
        push = o.warm_bound_push if bound_push is None else bound_push
        key = (warm, push if warm else None)
        if key not in self._solvers:
            t0 = time.perf_counter()
            ipopt = {
                "linear_solver": o.linear_solver,
                "mumps_pivot_order": o.mumps_pivot_order,
                "tol": o.tol,
                "acceptable_tol": o.acceptable_tol,
                "acceptable_iter": 5,
                "max_iter": o.max_iter,
                "print_level": 0,
                "sb": "yes",
                # the NLP is scaled by construction; MUMPS' own scaling cost time and
                # iterations in the measurements of benchmarks/optimize_solve.py
                "mumps_scaling": 0,
                "mumps_permuting_scaling": 0,
            }
            if warm:
                ipopt.update(
                    {
                        "warm_start_init_point": "yes",
                        "mu_init": o.warm_mu_init,
                        "warm_start_bound_push": push,
                        "warm_start_bound_frac": push,
                        "warm_start_slack_bound_push": push,
                        "warm_start_slack_bound_frac": push,
                        "warm_start_mult_bound_push": push,
                    }
                )
            _single_threaded_blas()
            self._solvers[key] = ca.nlpsol(
                "pumping_cycle",
                "ipopt",
                self.nlp,
                {"ipopt": ipopt, "print_time": False, "error_on_fail": False,
                 **self.derivatives()},
            )
            log.debug("created %s IPOPT solver in %.1f s", "warm" if warm else "cold",
                      time.perf_counter() - t0)
        return self._solvers[key]

    def params(
        self,
        wind_ref_m_s: float,
        w_elec: float = 0.0,
        w_mech: float = 0.0,
        w_reg: float | None = None,
        w_track: float = 0.0,
        w_fict: float = 0.0,
        x_ref: np.ndarray | None = None,
    ) -> np.ndarray:
        """NLP parameter vector.

        Parameters
        ----------
        wind_ref_m_s : float
            Wind speed at 100 m [m/s].
        w_elec, w_mech : float
            Weights of the average electrical / mechanical power [per scaled power].
        w_reg : float, optional
            Regularization weight [per scaled power]; defaults to
            ``options.regularization_w`` over the power scale.
        w_track, w_fict : float
            Homotopy weights: state tracking and fictitious-force penalty.
        x_ref : ndarray (NX, N d + 1), optional
            Tracking reference at the state grid points [SI].
        """
        lay = self.layout
        p = np.zeros(lay.n_p)
        if w_reg is None:
            w_reg = self.options.regularization_w / self.scales.power_w
        p[: len(PARAM_NAMES)] = [wind_ref_m_s, w_elec, w_mech, w_reg, w_track, w_fict]
        if x_ref is not None:
            p[lay.i_p_ref] = x_ref / self.scales.state[:, None]
        return p

    def bounds(
        self, drive_limits: bool, fix_fictitious: bool, period_s: float | None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Scaled ``lbx, ubx, lbg, ubg`` for a configuration.

        ``period_s`` fixes the period when given; ``fix_fictitious`` pins the
        fictitious forces at zero (the physical model).
        """
        lay, o = self.layout, self.options
        lbw, ubw, lbg, ubg = self.lbw.copy(), self.ubw.copy(), self.lbg.copy(), self.ubg.copy()
        if drive_limits:
            kite = self.dae.kite
            dl_max = max_reel_speed_m_s(o.max_speed_rpm / kite.gear_ratio, kite.r_winch_m)
            idx = lay.i_x[km.IDX["dl_m_s"]]
            lbw[idx] = -dl_max / self.scales.state[km.IDX["dl_m_s"]]
            ubw[idx] = dl_max / self.scales.state[km.IDX["dl_m_s"]]
            ubg[lay.g_torque] = np.minimum(ubg[lay.g_torque],
                                           o.max_torque_nm / self.scales.torque_nm)
            if o.max_p_elec_w is not None:
                lbg[lay.g_p_elec] = -o.max_p_elec_w / self.scales.power_w
                ubg[lay.g_p_elec] = o.max_p_elec_w / self.scales.power_w
            if lay.g_rms.size:
                ubg[lay.g_rms] = (o.max_rms_torque_nm / self.scales.torque_nm) ** 2
        if fix_fictitious:
            lbw[lay.i_f.ravel()] = 0.0
            ubw[lay.i_f.ravel()] = 0.0
        if period_s is not None:
            # fix the first copy only: the copies follow through their equality rows
            # (fixing all would leave those rows with an empty Jacobian)
            lbw[lay.i_period[0]] = ubw[lay.i_period[0]] = period_s / self.scales.period_s
        return lbw, ubw, lbg, ubg

    def pack(self, x: np.ndarray, z: np.ndarray, u: np.ndarray, fict: np.ndarray,
             period_s: float) -> np.ndarray:
        """Scaled decision vector from physical arrays (shapes as in :class:`Layout`)."""
        lay = self.layout
        w = np.zeros(lay.n_w)
        w[lay.i_period] = period_s
        w[lay.i_x] = x
        w[lay.i_z] = z
        w[lay.i_u] = u
        w[lay.i_f] = fict
        return w / lay.scale_w

    def unpack(self, w_scaled: np.ndarray) -> dict[str, np.ndarray | float]:
        """Physical period, states, algebraic variables, controls, fictitious forces."""
        lay = self.layout
        w = np.asarray(w_scaled).ravel() * lay.scale_w
        return {
            "period_s": float(w[lay.i_period[0]]),
            "x": w[lay.i_x],
            "z": w[lay.i_z],
            "u": w[lay.i_u],
            "fict": w[lay.i_f],
        }


def build_ocp(
    dae: KiteDae, drive_model: DriveModel, options: OcpOptions | None = None,
    system: Any = None,
) -> Ocp:
    """Build the scaled collocation NLP once for given options and drive model.

    Parameters
    ----------
    dae : KiteDae
        The kite model (:func:`optimize.model.kite_model.kite_dae`).
    drive_model : DriveModel
        Electrical power model of the drive (``fitting.model_file.PowerModel``).
    options : OcpOptions, optional
        Discretization and limits; defaults to :class:`OcpOptions`.
    system : optimize.system.system.System, optional
        The system ``dae`` and the limits of ``options`` come from (recorded on
        the OCP; the stored initial guess is accepted only for its own system).

    Returns
    -------
    Ocp
        The NLP with its layout and base bounds (no drive limits, free
        period, free fictitious forces); IPOPT solvers are created lazily.
    """
    t0 = time.perf_counter()
    o = options or OcpOptions()
    deg = np.pi / 180
    loop = start_loop(dae.kite, dae.coeffs, dae.wind, o.alpha_bounds_deg[1], o.min_airspeed_m_s,
                      o.period_bounds_s, o.tether_length_bounds_m, o.min_altitude_m)
    sc = system_scales(dae.kite, loop, o.nominal_power_w, o.max_torque_nm,
                       o.surface_bound_deg * deg, o.surface_rate_bound_rad_s)
    coll = radau(o.degree)
    n, d = o.n_intervals, o.degree
    nx, nz, nu, nf = km.NX, km.NZ, km.NU, km.NF
    n_points, n_coll = n * d + 1, n * d

    # ---- layout of w
    counter = iter(range(10**9))
    i_period = np.array([next(counter) for _ in range(n)])
    i_x = np.array([[next(counter) for _ in range(nx)] for _ in range(n_points)]).T
    i_z = np.array([[next(counter) for _ in range(nz)] for _ in range(n_coll)]).T
    i_u = np.array([[next(counter) for _ in range(nu)] for _ in range(n)]).T
    i_f = np.array([[next(counter) for _ in range(nf)] for _ in range(n_coll)]).T
    n_w = next(counter)
    scale_w = np.ones(n_w)
    scale_w[i_period] = sc.period_s
    scale_w[i_x] = sc.state[:, None]
    scale_w[i_z] = sc.algebraic[:, None]
    scale_w[i_u] = sc.control[:, None]
    scale_w[i_f] = sc.fictitious[:, None]

    n_par = len(PARAM_NAMES)
    n_p = n_par + nx * n_points
    i_p_ref = n_par + np.arange(nx * n_points).reshape(n_points, nx).T

    w = ca.SX.sym("w", n_w)
    p = ca.SX.sym("p", n_p)
    wind, w_elec, w_mech, w_reg, w_track, w_fict = (p[i] for i in range(n_par))
    ws = w * ca.DM(scale_w)

    def col(idx: np.ndarray, k: int) -> ca.SX:
        return ws[[int(i) for i in idx[:, k]]]

    xs = [col(i_x, k) for k in range(n_points)]
    zs = [col(i_z, k) for k in range(n_coll)]
    us = [col(i_u, k) for k in range(n)]
    fs = [col(i_f, k) for k in range(n_coll)]

    r_w, gear = dae.kite.r_winch_m, dae.kite.gear_ratio
    g, lbg, ubg = [], [], []
    g_torque, g_periodic, g_p_elec = [], [], []
    n_g = 0

    def add(expr, lo, hi, tag=None):
        nonlocal n_g
        size = expr.shape[0]
        g.append(expr)
        lbg.extend(np.broadcast_to(lo, (size,)).tolist())
        ubg.extend(np.broadcast_to(hi, (size,)).tolist())
        if tag is not None:
            tag.extend(range(n_g, n_g + size))
        n_g += size

    out_names = dae.outputs.name_out()
    inv_sx = ca.DM(1.0 / sc.state)
    inv_res = ca.DM(1.0 / sc.residual)
    v_sc = sc.airspeed_m_s
    v_top, torque_top = kite_limit_bounds(o, r_w, gear)
    p_elec_avg, p_mech_avg, reg, track, fict_pen, torque_sq_avg = 0, 0, 0, 0, 0, 0
    for k in range(n):
        u_k = us[k]
        h = ws[int(i_period[k])] / n
        reg += ca.sumsqr(u_k / ca.DM(o.control_sigma)) / n
        for j in range(1, d + 1):
            ip = k * d + j  # grid point of this Radau point
            ic = k * d + j - 1  # Radau point index
            x_kj, z_kj = xs[ip], zs[ic]
            xp = sum(coll.deriv[r, j - 1] * xs[k * d + r] for r in range(d + 1))
            add((xp - h * dae.ode(x_kj, u_k, z_kj)) * inv_sx, 0.0, 0.0)
            add(dae.alg(x_kj, u_k, z_kj, wind, fs[ic]) * inv_res, 0.0, 0.0)
            out = dict(zip(out_names, dae.outputs(x_kj, u_k, z_kj, wind), strict=True))
            add(out["airspeed_m_s"] / v_sc, o.min_airspeed_m_s / v_sc, v_top / v_sc)
            add(out["alpha_rad"] / (10 * deg), o.alpha_bounds_deg[0] / 10,
                o.alpha_bounds_deg[1] / 10)
            add(out["beta_rad"] / (10 * deg), o.beta_bounds_deg[0] / 10,
                o.beta_bounds_deg[1] / 10)
            add(out["cos_line_angle"], np.cos(o.max_line_angle_deg * deg), np.inf)
            l_kj, dl_kj, nu_kj = x_kj[km.IDX["l_m"]], x_kj[km.IDX["dl_m_s"]], z_kj[6]
            tension = l_kj * nu_kj
            torque = motor_torque_nm(tension, r_w, gear)
            add(torque / sc.torque_nm, -np.inf, torque_top / sc.torque_nm, tag=g_torque)
            p_mech = mechanical_power_w(tension, dl_kj)
            p_elec = drive_model.casadi_p_elec_w(motor_speed_rpm(dl_kj, r_w, gear), torque)
            if o.max_p_elec_w is not None:
                add(p_elec / sc.power_w, -np.inf, np.inf, tag=g_p_elec)
            p_elec_avg += coll.quad[j - 1] * p_elec / n
            p_mech_avg += coll.quad[j - 1] * p_mech / n
            torque_sq_avg += coll.quad[j - 1] * (torque / sc.torque_nm) ** 2 / n
            fict_pen += ca.sumsqr(fs[ic] / ca.DM(sc.fictitious)) / n_coll
    for k in range(n_points):
        ref = p[[int(i) for i in i_p_ref[:, k]]]
        track += ca.sumsqr(xs[k] * inv_sx - ref) / n_points

    # one period copy per interval keeps the KKT matrix banded (no dense period column)
    add(ca.vertcat(*[(ws[int(i_period[k + 1])] - ws[int(i_period[k])]) / sc.period_s
                     for k in range(n - 1)]), 0.0, 0.0)
    # invariants at t = 0 (c, dc/dt, orthonormal R)
    c0, cdot0, orth0 = dae.invariants(xs[0])
    add(c0 / sc.c_m2, 0.0, 0.0)
    add(cdot0 / sc.cdot_m2_s, 0.0, 0.0)
    add(ca.vertcat(*[orth0[a, b] for a in range(3) for b in range(a, 3)]), 0.0, 0.0)
    # periodicity
    per = [km.IDX[name] for name in PERIODIC_STATES]
    add((xs[-1][per] - xs[0][per]) * ca.DM(1.0 / sc.state[per]), 0.0, 0.0, g_periodic)
    dcm0 = ca.reshape(xs[0][6:15], 3, 3)
    dcm_t = ca.reshape(xs[-1][6:15], 3, 3)
    rel = ca.mtimes(dcm0.T, dcm_t)
    add(ca.vertcat(rel[0, 1], rel[0, 2], rel[1, 2]), 0.0, 0.0, g_periodic)
    g_rms: list[int] = []
    if o.max_rms_torque_nm is not None:  # last row: bounded in bounds() with the limits
        add(torque_sq_avg, -np.inf, np.inf, tag=g_rms)

    objective = (
        (w_elec * p_elec_avg + w_mech * p_mech_avg) / sc.power_w
        + w_reg * reg
        + w_track * track
        + w_fict * fict_pen
    )
    nlp = {"x": w, "p": p, "f": objective, "g": ca.vertcat(*g)}

    # ---- base bounds (physical, then scaled)
    lbw = np.full(n_w, -np.inf)
    ubw = np.full(n_w, np.inf)
    lbw[i_period], ubw[i_period] = o.period_bounds_s
    l_lo, l_hi = o.tether_length_bounds_m
    reach = 4.0 * l_hi  # position bounds: never active, they only keep IPOPT in range
    z_top = o.min_altitude_m - dae.wind.origin_altitude_m  # r_z <= -(clearance above winch)
    state_lo = {
        "r_x_m": -reach, "r_y_m": -reach, "r_z_m": -reach, "v_x_m_s": -200, "v_y_m_s": -200,
        "v_z_m_s": -200, "omega_x_rad_s": -6 * np.pi, "omega_y_rad_s": -6 * np.pi,
        "omega_z_rad_s": -6 * np.pi, "l_m": l_lo, "dl_m_s": -100, "ddl_m_s2": -500,
        "aileron_rad": -o.surface_bound_deg * deg, "elevator_rad": -o.surface_bound_deg * deg,
        "rudder_rad": -o.surface_bound_deg * deg,
    }
    state_hi = {
        "r_x_m": reach, "r_y_m": reach, "r_z_m": -z_top, "v_x_m_s": 200, "v_y_m_s": 200,
        "v_z_m_s": 200, "omega_x_rad_s": 6 * np.pi, "omega_y_rad_s": 6 * np.pi,
        "omega_z_rad_s": 6 * np.pi, "l_m": l_hi, "dl_m_s": 100, "ddl_m_s2": 500,
        "aileron_rad": o.surface_bound_deg * deg, "elevator_rad": o.surface_bound_deg * deg,
        "rudder_rad": o.surface_bound_deg * deg,
    }
    for name in km.STATE_NAMES:
        i = km.IDX[name]
        lo, hi = (-1.1, 1.1) if name.startswith("dcm_") else (state_lo[name], state_hi[name])
        lbw[i_x[i]] = lo
        ubw[i_x[i]] = hi
    lbw[i_x[km.IDX["r_y_m"], 0]] = ubw[i_x[km.IDX["r_y_m"], 0]] = 0.0  # r_y(0) = 0
    lbw[i_z[6]] = 0.0  # tension = l nu >= 0
    rate = o.surface_rate_bound_rad_s
    lbw[i_u[0]], ubw[i_u[0]] = -5000.0, 5000.0
    lbw[i_u[1:]], ubw[i_u[1:]] = -rate, rate

    ocp = Ocp(
        options=o,
        dae=dae,
        coll=coll,
        layout=Layout(
            n_points=n_points, n_coll=n_coll, i_period=i_period, i_x=i_x, i_z=i_z, i_u=i_u,
            i_f=i_f, scale_w=scale_w, n_w=n_w, n_g=n_g, g_torque=np.array(g_torque),
            g_p_elec=np.array(g_p_elec, dtype=int),
            g_periodic=np.array(g_periodic), n_p=n_p,
            i_p_ref=i_p_ref, g_rms=np.array(g_rms, dtype=int),
        ),
        nlp=nlp,
        lbw=lbw / scale_w,
        ubw=ubw / scale_w,
        lbg=np.array(lbg),
        ubg=np.array(ubg),
        build_time_s=0.0,
        drive_model=drive_model,
        scales=sc,
        loop=loop,
        system=system,
    )
    ocp.build_time_s = time.perf_counter() - t0
    log.info("built OCP: %d variables, %d constraints, N=%d, degree %d in %.1f s",
             n_w, n_g, n, d, ocp.build_time_s)
    return ocp


def kite_limit_bounds(options: OcpOptions, drum_radius_m: float,
                      gear_ratio: float) -> tuple[float, float]:
    """Upper bounds of the airspeed [m/s] and motor-torque [N m] rows in every kind.

    The kite's airspeed limit and its tether-force limit, the latter as the motor
    torque that holds that tension on the drum (``inf`` where none is given). The
    drive's torque limit of the constrained kinds comes on top (the smaller wins,
    :meth:`Ocp.bounds`); the rows are the same, so a stored initial guess of the NLP
    without kite limits still fits.
    """
    o = options
    v_top = np.inf if o.max_airspeed_m_s is None else o.max_airspeed_m_s
    torque_top = (np.inf if o.max_tether_force_n is None
                  else float(motor_torque_nm(o.max_tether_force_n, drum_radius_m, gear_ratio)))
    return v_top, torque_top


def grid_times(ocp: Ocp, period_s: float) -> np.ndarray:
    """Times [s] of the ``N d + 1`` state grid points for a period."""
    n, coll = ocp.options.n_intervals, ocp.coll
    h = period_s / n
    t = [0.0] + [h * (k + coll.tau[j]) for k in range(n) for j in range(1, coll.degree + 1)]
    return np.array(t)
