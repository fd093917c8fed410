"""Options of the cycle OCP in three groups: discretization, limits, solver.

* :class:`Discretization`: how the cycle is transcribed (intervals, collocation
  degree, the control regularization that keeps the discretized controls smooth).
* :class:`Limits`: the physical bounds of one system and its drive. They come from
  the system file (:meth:`optimize.system.system.System.ocp_options`); the defaults
  here are the shipped ``highwind.toml`` system's kite bounds, and the drive's limits
  default to the power model's own rating (:func:`with_drive_rating`).
* :class:`SolverOptions`: which NLP solver runs and how (tolerances, warm starts,
  linear solver, the stored initial guess).

:class:`OcpOptions` holds one of each; ``OcpOptions()`` is the default problem::

    options = OcpOptions(Discretization(n_intervals=20), solver=SolverOptions(tol=1e-8))
    options.discretization.n_intervals, options.limits.max_torque_nm, options.solver.tol
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

#: the reel speed's and the body rates' bounds when the system states none: the solver's
#: range [m/s], [rad/s] (three turns a second)
SOLVER_REEL_SPEED_M_S, SOLVER_BODY_RATE_RAD_S = 100.0, 6 * math.pi

#: most collocation intervals per period: the default is 40 and the trust check's mesh
#: refinement doubles it; 400 already means ~10^5 NLP variables and minutes per solve
MAX_INTERVALS = 400
#: documented minimum mesh: collocation points per cycle (intervals x degree); coarser
#: optima the result check flags (:mod:`optimize.analysis.result_check`)
MIN_COLLOCATION_POINTS = 40


@dataclass(frozen=True)
class Discretization:
    """How the periodic cycle is transcribed into an NLP.

    Parameters
    ----------
    n_intervals : int
        Number of collocation intervals over one period.
    degree : int
        Radau collocation degree.
    regularization_w : float
        Weight of the control regularization ``mean_k sum_i (u_i / sigma_i)^2``
        [W]. The default 0.1 W is the weight of the reference
        implementation (rawesome ``pumping_poweropt.py``: 0.1 (u/sigma)^2 in W).
    control_sigma : (float, float, float, float)
        Scales ``sigma`` of tether jerk [m/s^3] and aileron, elevator, rudder
        rates [rad/s]. Default (10, 1, 1, 1). The reference implementation
        used (10, 0.001, 0.8, 0.1), which practically freezes the aileron; at
        N = 40 and 7 m/s that reproduces the reference prototype's table to the watt
        (-1528 W / -48 W / 3.36 s mechanical) but leaves the 10 m/s periods
        further from the paper's (2.39 s and 4.2 s against 2.14 s and 3.89 s;
        the default gives 2.22 s and 3.82 s).
    """

    n_intervals: int = 40
    degree: int = 4
    regularization_w: float = 0.1
    control_sigma: tuple[float, float, float, float] = (10.0, 1.0, 1.0, 1.0)

    def __post_init__(self) -> None:
        if not 2 <= self.n_intervals <= MAX_INTERVALS:
            raise ValueError(f"n_intervals must be 2 to {MAX_INTERVALS}, got {self.n_intervals}")
        if not 1 <= self.degree <= 9:
            raise ValueError(f"degree must be 1 to 9, got {self.degree}")
        if len(self.control_sigma) != 4 or min(self.control_sigma) <= 0:
            raise ValueError(f"control_sigma must be 4 positive scales, got {self.control_sigma}")


@dataclass(frozen=True)
class Limits:
    """Physical bounds of the system and its drive (from the system file).

    Parameters
    ----------
    period_bounds_s : (float, float)
        Bounds on the free period [s].
    tether_length_bounds_m : (float, float)
        Bounds on the tether length [m].
    min_altitude_m : float
        Lowest CG altitude above ground [m] (the system's ground clearance).
    max_speed_rpm, max_torque_nm : float or None
        Drive limits of the constrained scenarios at the motor shaft [rpm], [N m];
        ``None``: the power model's rating (:func:`with_drive_rating`).
    max_p_elec_w : float or None
        Limit of the electrical power drawn or fed [W] in the constrained
        scenarios (rows only when set).
    nominal_power_w : float or None
        The drive's nominal power [W]: the objective's scale; ``None``: the power
        model's.
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
    surface_bounds_deg : (float, float, float)
        Deflection bounds of the aileron, elevator and rudder [deg].
    surface_rate_bound_rad_s : float
        Control-surface rate bound [rad/s].
    max_reel_acceleration_m_s2 : float or None
        Largest tether (reel) acceleration ``|l''|`` [m/s^2] of every scenario kind (the
        winch's limit); ``None``: only the solver's range (500 m/s^2).
    max_reel_jerk_m_s3 : float or None
        Largest tether (reel) jerk ``|dddl|`` [m/s^3], the OCP's control, of every
        scenario kind; ``None``: only the solver's range (5000 m/s^3).
    max_reel_out_speed_m_s, max_reel_in_speed_m_s : float or None
        Largest reel-out speed ``l'`` and reel-in speed ``-l'`` [m/s] of every scenario
        kind (the winch's limits; the drive's speed limit of the constrained kinds
        comes on top, the smaller wins); ``None``: only the solver's range (100 m/s).
    max_body_rate_deg_s : float or None
        Largest magnitude of each body rate p, q, r [deg/s] of every kind; ``None``:
        only the solver's range (1080 deg/s).
    min_tension_n : float or None
        Smallest tether tension [N] of every kind; ``None``: tension >= 0.
    base_speed_rpm : float or None
        The drive's base speed at the motor shaft [rpm]: above it the largest torque
        falls as ``max_torque_nm * base / |n|`` (constant power), in the constrained
        scenarios. ``None``: no constant-power region.
    envelope_speed_rpm, envelope_torque_nm : tuple of float or None
        A datasheet's torque-speed envelope instead: the largest torque [N m] at each
        motor speed [rpm] (speeds rising from 0, torques not rising), linear between
        the points and flat beyond the last, in both quadrants, in the constrained
        scenarios.
    max_winding_temperature_c : float or None
        The drive's thermal rating: the largest winding temperature [degC] in the
        constrained scenarios. With a power model that has a thermal model, the
        winding temperature is a periodic state of the OCP and this bound replaces
        the RMS-torque row; ``None``: no thermal state.
    ambient_temperature_c : float or None
        Ambient (or coolant) temperature of the thermal model [degC]; ``None``: the
        one the thermal model was fitted with.
    """

    period_bounds_s: tuple[float, float] = (1.0, 20.0)
    tether_length_bounds_m: tuple[float, float] = (1.0, 500.0)
    min_altitude_m: float = 2.0
    max_speed_rpm: float | None = None
    max_torque_nm: float | None = None
    max_p_elec_w: float | None = None
    nominal_power_w: float | None = None
    max_rms_torque_nm: float | None = None
    min_airspeed_m_s: float = 10.0
    max_airspeed_m_s: float | None = None
    max_tether_force_n: float | None = None
    alpha_bounds_deg: tuple[float, float] = (-4.5, 8.5)
    beta_bounds_deg: tuple[float, float] = (-9.0, 9.0)
    max_line_angle_deg: float = 65.0
    surface_bounds_deg: tuple[float, float, float] = (10.0, 10.0, 10.0)
    surface_rate_bound_rad_s: float = 2.0
    max_reel_acceleration_m_s2: float | None = None
    max_reel_jerk_m_s3: float | None = None
    max_reel_out_speed_m_s: float | None = None
    max_reel_in_speed_m_s: float | None = None
    max_body_rate_deg_s: float | None = None
    min_tension_n: float | None = None
    base_speed_rpm: float | None = None
    envelope_speed_rpm: tuple[float, ...] | None = None
    envelope_torque_nm: tuple[float, ...] | None = None
    max_winding_temperature_c: float | None = None
    ambient_temperature_c: float | None = None

    def __post_init__(self) -> None:
        lo, hi = self.period_bounds_s
        if not 0 < lo < hi:
            raise ValueError(
                f"period_bounds_s must satisfy 0 < lo < hi, got {self.period_bounds_s}"
            )
        for name in ("max_rms_torque_nm", "max_airspeed_m_s", "max_tether_force_n",
                     "max_reel_acceleration_m_s2", "max_reel_jerk_m_s3", "base_speed_rpm",
                     "max_reel_out_speed_m_s", "max_reel_in_speed_m_s", "max_body_rate_deg_s"):
            value = getattr(self, name)
            if value is not None and not value > 0:
                raise ValueError(f"{name} must be > 0, got {value}")
        if self.min_tension_n is not None and not self.min_tension_n >= 0:
            raise ValueError(f"min_tension_n must be >= 0, got {self.min_tension_n}")

    def reel_speed_range_m_s(self) -> tuple[float, float]:
        """The reel speed ``l'`` range of every kind [m/s]: the winch's limits, the
        solver's range of :data:`SOLVER_REEL_SPEED_M_S` where unstated."""
        return (-(self.max_reel_in_speed_m_s or SOLVER_REEL_SPEED_M_S),
                self.max_reel_out_speed_m_s or SOLVER_REEL_SPEED_M_S)

    def body_rate_bound_rad_s(self) -> float:
        """The bound of each body rate of every kind [rad/s]: the system's, the solver's
        range of :data:`SOLVER_BODY_RATE_RAD_S` where unstated."""
        if self.max_body_rate_deg_s is None:
            return SOLVER_BODY_RATE_RAD_S
        return self.max_body_rate_deg_s * math.pi / 180


#: NLP solvers the OCP can be handed to
SOLVERS = ("ipopt", "fatrop")
#: the solvers that take the collocation's stage-wise layout (Riccati-based)
STAGEWISE_SOLVERS = ("fatrop",)
#: transcriptions the solver runs on (:mod:`optimize.problem.transcriptions`,
#: :mod:`optimize.problem.transcriptions.condensed_nlp`)
TRANSCRIPTIONS = ("collocation", "condensed")


@dataclass(frozen=True)
class SolverOptions:
    """Which NLP solver runs and with which settings.

    Parameters
    ----------
    solver : str
        NLP solver (one of :data:`SOLVERS`): ``"ipopt"`` (the default: IPOPT on the
        general sparse layout) or ``"fatrop"`` (a Riccati-based interior-point solver
        shipped with CasADi, on the stage-wise layout of the same NLP; it takes no dual
        warm start, and on this OCP it is slower per iteration and less robust than
        IPOPT with MUMPS, see ``benchmarks/solver_comparison.py``).
    tol : float
        Convergence tolerance (scaled problem).
    acceptable_tol : float
        IPOPT acceptable tolerance.
    max_iter : int
        Iteration limit per solve.
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
        guess (:mod:`optimize.solve.starts.stored_guess`) when it fits, instead of the homotopy.
    start_file : str or None
        A start file of the stored guess's format to use instead of the shipped one
        (a sweep's ``start.npz``); None: the shipped file.
    linear_solver : str
        IPOPT linear solver: ``"mumps"`` (default), ``"spral"``, or one IPOPT loads
        at run time from the user's library (HSL ``"ma27"``, ``"ma57"``, ``"ma77"``,
        ``"ma86"``, ``"ma97"`` from ``libhsl.so``; ``"pardiso"``); checked by
        :func:`optimize.solve.backend.check_linear_solver`.
    mumps_pivot_order : int
        MUMPS fill-reducing ordering (0 AMD, 2 AMF, 4 PORD, 6 QAMD, 7 automatic).
        AMD makes an iteration on this NLP cheaper than the automatic choice
        (measured by ``benchmarks/optimize_solve.py``, figures in benchmarks/README.md).
    transcription : str
        What the solver runs on (one of :data:`TRANSCRIPTIONS`): ``"collocation"`` (the
        default: every Radau point's states and algebraic variables are NLP variables)
        or ``"condensed"`` (multiple shooting, each interval's collocation solved inside
        the interval, :mod:`optimize.problem.transcriptions.condensed_nlp`). Both have the
        same optima; results and warm starts are in the collocation layout either way.
    codegen : bool
        Compile the NLP's repeated functions to C where a C compiler is found
        (:mod:`optimize.problem.transcriptions.codegen`, cached by hash, so only the first
        use of a model compiles): the Radau point's Jacobian and Hessian for ``"collocation"``, each
        interval's solve and derivatives for ``"condensed"``. Off by default: it needs a
        C compiler, and on the paper sweep it saved 17 % of the CPU after 3 s of gcc
        (collocation) and 16 % after 34 s (condensed) (benchmarks/README.md); False runs
        them in CasADi's virtual machine.
    predictor_step : float
        Fraction of the tangential predictor's step (:mod:`optimize.solve.starts.predictor`)
        a warm start from another wind speed or objective takes: 0 (the default) starts
        from the neighbour's optimum as it is; 1 from the first-order prediction of the
        new optimum. Off by default: on the paper sweep it saved no iterations at these
        warm-start settings and costs a KKT factorization per start
        (``benchmarks/warm_start_predictor.py``, figures in benchmarks/README.md).
    """

    solver: str = "ipopt"
    tol: float = 1e-6
    acceptable_tol: float = 1e-4
    max_iter: int = 1000
    warm_mu_init: float = 1e-4
    warm_bound_push: float = 1e-2
    stored_guess: bool = True
    start_file: str | None = None
    linear_solver: str = "mumps"
    mumps_pivot_order: int = 0
    transcription: str = "collocation"
    codegen: bool = False
    predictor_step: float = 0.0

    def __post_init__(self) -> None:
        if self.solver not in SOLVERS:
            raise ValueError(f"solver must be one of {', '.join(SOLVERS)}, got {self.solver!r}")
        if self.transcription not in TRANSCRIPTIONS:
            raise ValueError(f"transcription must be one of {', '.join(TRANSCRIPTIONS)}, "
                             f"got {self.transcription!r}")
        if not 0 < self.warm_bound_push <= 0.5:  # IPOPT's range of warm_start_bound_frac
            raise ValueError(f"warm_bound_push must be in (0, 0.5], got {self.warm_bound_push}")
        if not 0 <= self.predictor_step <= 1:
            raise ValueError(f"predictor_step must be in [0, 1], got {self.predictor_step}")

    @property
    def stagewise(self) -> bool:
        """Whether the solver takes the stage-wise layout (:data:`STAGEWISE_SOLVERS`)."""
        return self.solver in STAGEWISE_SOLVERS


@dataclass(frozen=True)
class OcpOptions:
    """All options of the OCP: one :class:`Discretization`, :class:`Limits` and
    :class:`SolverOptions` each (defaults: the default of each group)."""

    discretization: Discretization = field(default_factory=Discretization)
    limits: Limits = field(default_factory=Limits)
    solver: SolverOptions = field(default_factory=SolverOptions)

    def replace(self, **groups: dict[str, Any]) -> OcpOptions:
        """These options with fields of groups replaced, e.g.
        ``options.replace(limits={"max_torque_nm": 60.0})``."""
        unknown = set(groups) - {f.name for f in dataclasses.fields(self)}
        if unknown:
            raise TypeError(f"unknown option groups: {', '.join(sorted(unknown))}")
        return dataclasses.replace(self, **{
            name: dataclasses.replace(getattr(self, name), **changes)
            for name, changes in groups.items()})

    def as_dict(self) -> dict[str, dict[str, Any]]:
        """``{group: {field: value}}`` (JSON-ready; :meth:`from_dict` reads it back)."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, raw: dict[str, Any]) -> OcpOptions:
        """Options from :meth:`as_dict` output (lists back to tuples).

        Raises
        ------
        TypeError, ValueError
            An unknown group or field, or a value out of range.
        """
        if not isinstance(raw, dict):
            raise TypeError(f"OCP options must be a mapping of groups, got {type(raw).__name__}")
        types = {f.name: f.default_factory for f in dataclasses.fields(cls)}
        unknown = set(raw) - set(types)
        if unknown:
            raise TypeError(f"unknown option groups: {', '.join(sorted(unknown))}")
        groups = {}
        for name, values in raw.items():
            if not isinstance(values, dict):
                raise TypeError(f"option group {name}: not a mapping")
            groups[name] = types[name](**{k: tuple(v) if isinstance(v, list) else v
                                          for k, v in values.items()})
        return cls(**groups)


#: the drive limits :class:`Limits` may leave to the power model's rating
DRIVE_LIMITS = ("max_speed_rpm", "max_torque_nm", "nominal_power_w")


def with_drive_rating(options: OcpOptions, drive_model: Any) -> OcpOptions:
    """``options`` with the drive limits it leaves open (``None``) from the power model's
    rating (``drive_model.drive``; the nominal power also from ``nominal_power_w``).

    Raises
    ------
    ValueError
        A limit left open that the power model does not state either.
    """
    lim = options.limits
    open_keys = [k for k in DRIVE_LIMITS if getattr(lim, k) is None]
    if not open_keys:
        return options
    rating = dict(getattr(drive_model, "drive", None) or {})
    rating.setdefault("nominal_power_w", getattr(drive_model, "nominal_power_w", None))
    missing = [k for k in open_keys if rating.get(k) is None]
    if missing:
        raise ValueError(f"drive limits {', '.join(missing)}: not in the OCP options and not "
                         "in the power model's rating (give the system's drive)")
    return options.replace(limits={k: float(rating[k]) for k in open_keys})
