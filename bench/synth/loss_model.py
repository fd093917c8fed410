"""The synthetic drive's true electrical power: the paper's quadratic plus physics it misses.

Drum frame (docs/schemas.md): speed ``n`` in rpm, signed (reel-out / generating is
negative), torque ``T >= 0`` in N m; ``P_elec`` in W, positive = drawn from the grid.

    P_elec = c0 + c1 n^2 + c2 T^2 (1 + k_cu (theta - theta_ref)) + c3 n T   (paper eq. 4 core)
           + c_f |omega|              bearing and seal friction
           + c_fe |n|^1.6             iron (hysteresis + eddy-current) loss
           + c_g |omega T|            gear-mesh loss, a loss in both power-flow directions
           + P_fan(theta)             cabinet fan on the same grid connection, speed
                                      rising with the winding temperature

``k_cu = alpha_cu * copper_share``: only the copper part of the T^2 loss drifts with
the winding temperature ``theta`` (alpha_cu = 0.00393 / K for copper). The winding
temperature follows a first-order thermal model driven by the losses
(:func:`theta_step`). The core coefficients ``c0..c3`` are calibrated
(:func:`calibrate_core`) so that an ordinary least-squares fit of the paper's four
terms to the campaign's operating points returns the paper's ``a0..a3`` (docs/paper_figures.md §1).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from kernel.units import RPM_PER_RAD_S

#: paper Table I (docs/paper_figures.md §1), rpm convention: a0 [W], a1 [W/rpm^2],
#: a2 [W/(N m)^2], a3 [W/(rpm N m)]
PAPER_QUADRATIC: tuple[float, float, float, float] = (
    293.5816373499238,
    0.0003931623408,
    0.0665919381751,
    0.1078628659825,
)



@dataclass(frozen=True)
class LossModel:
    """Parameters of the true drive loss model (all in the drum frame).

    Parameters
    ----------
    c0_w : float
        Constant part of the core quadratic [W].
    c1_w_per_rpm2 : float
        Speed-squared coefficient of the core [W/rpm^2].
    c2_w_per_nm2 : float
        Torque-squared coefficient of the core at ``theta_ref_c`` [W/(N m)^2].
    c3_w_per_rpm_nm : float
        Speed-torque coefficient of the core (mechanical power plus proportional
        losses) [W/(rpm N m)].
    friction_w_s_per_rad : float
        Friction loss per unit of absolute shaft speed [W/(rad/s)].
    iron_w_per_rpm1p6 : float
        Iron loss coefficient on ``|n|^1.6`` [W/rpm^1.6].
    gear_loss_fraction : float
        Gear-mesh loss as a fraction of the absolute mechanical power [-].
    fan_max_w : float
        Electrical power of the cabinet fan at full speed [W].
    fan_start_c : float
        Winding temperature at which the fan starts [degC].
    fan_full_c : float
        Winding temperature at which the fan runs at full speed [degC].
    alpha_cu_per_k : float
        Temperature coefficient of copper resistance [1/K].
    copper_share : float
        Share of the ``T^2`` loss that is copper (winding) loss [-].
    theta_ref_c : float
        Winding temperature at which ``c2_w_per_nm2`` holds [degC].
    r_th_k_per_w : float
        Thermal resistance winding -> ambient [K/W].
    tau_th_s : float
        Thermal time constant of the winding [s].
    """

    c0_w: float
    c1_w_per_rpm2: float
    c2_w_per_nm2: float
    c3_w_per_rpm_nm: float
    friction_w_s_per_rad: float = 0.5
    iron_w_per_rpm1p6: float = 4.0e-4
    gear_loss_fraction: float = 0.01
    fan_max_w: float = 350.0
    fan_start_c: float = 40.0
    fan_full_c: float = 70.0
    alpha_cu_per_k: float = 0.00393
    copper_share: float = 1.0
    theta_ref_c: float = 20.0
    r_th_k_per_w: float = 0.05
    tau_th_s: float = 600.0

    @property
    def core(self) -> np.ndarray:
        """The core quadratic ``[c0, c1, c2, c3]`` (rpm convention)."""
        return np.array(
            [self.c0_w, self.c1_w_per_rpm2, self.c2_w_per_nm2, self.c3_w_per_rpm_nm]
        )

    def with_core(self, core) -> LossModel:
        """Return a copy with the core quadratic replaced by ``core`` (rpm convention)."""
        c0, c1, c2, c3 = (float(c) for c in core)
        return dataclasses.replace(
            self, c0_w=c0, c1_w_per_rpm2=c1, c2_w_per_nm2=c2, c3_w_per_rpm_nm=c3
        )

    def to_dict(self) -> dict[str, float]:
        """All parameters by field name (the unit is part of each name)."""
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, data: dict) -> LossModel:
        """Build from :meth:`to_dict` output; unknown or missing keys raise ``KeyError``."""
        names = {f.name for f in dataclasses.fields(cls)}
        unknown = set(data) - names
        missing = names - set(data)
        if unknown or missing:
            raise KeyError(f"LossModel keys: unknown {sorted(unknown)}, missing {sorted(missing)}")
        return cls(**{k: float(v) for k, v in data.items()})


#: the uncalibrated model: core equal to the paper's quadratic
DEFAULT_MODEL = LossModel(*PAPER_QUADRATIC)

#: the model in one line (n in rpm, omega in rad/s, T in N m, theta in degC, P in W)
FORMULA = (
    "p_elec_w = c0 + c1 n^2 + c2 T^2 (1 + alpha_cu copper_share (theta - theta_ref)) + c3 n T"
    " + friction |omega| + iron |n|^1.6 + gear_loss_fraction |omega T|"
    " + fan_max clip((theta - fan_start) / (fan_full - fan_start), 0, 1);"
    " tau_th dtheta/dt = ambient + r_th (p_elec - omega T - fan) - theta"
)


def fan_power_w(theta_c, model: LossModel = DEFAULT_MODEL) -> np.ndarray:
    """Cabinet-fan electrical power at winding temperature ``theta_c`` [degC] -> [W]."""
    span = model.fan_full_c - model.fan_start_c
    share = np.clip((np.asarray(theta_c, dtype=float) - model.fan_start_c) / span, 0.0, 1.0)
    return model.fan_max_w * share


def true_p_elec_w(
    speed_rpm, torque_nm, theta_c=None, model: LossModel = DEFAULT_MODEL
) -> np.ndarray:
    """True steady-state electrical power drawn from the grid.

    Parameters
    ----------
    speed_rpm : array_like
        Drum speed [rpm], negative when reeling out (generating).
    torque_nm : array_like
        Drum torque [N m], >= 0.
    theta_c : array_like, optional
        Winding temperature [degC]; defaults to ``model.theta_ref_c``.
    model : LossModel
        Loss-model parameters (a calibrated one is stored in ``truth.json``).

    Returns
    -------
    numpy.ndarray
        Electrical power [W], positive = drawn from the grid.
    """
    n = np.asarray(speed_rpm, dtype=float)
    t = np.asarray(torque_nm, dtype=float)
    theta = model.theta_ref_c if theta_c is None else np.asarray(theta_c, dtype=float)
    omega = n / RPM_PER_RAD_S
    k_cu = model.alpha_cu_per_k * model.copper_share
    core = (
        model.c0_w
        + model.c1_w_per_rpm2 * n**2
        + model.c2_w_per_nm2 * t**2 * (1.0 + k_cu * (theta - model.theta_ref_c))
        + model.c3_w_per_rpm_nm * n * t
    )
    extra = (
        model.friction_w_s_per_rad * np.abs(omega)
        + model.iron_w_per_rpm1p6 * np.abs(n) ** 1.6
        + model.gear_loss_fraction * np.abs(omega * t)
    )
    return core + extra + fan_power_w(theta, model)


def loss_w(speed_rpm, torque_nm, theta_c, model: LossModel = DEFAULT_MODEL) -> np.ndarray:
    """Heat dissipated in the drive (electrical minus mechanical power, fan excluded) [W]."""
    omega = np.asarray(speed_rpm, dtype=float) / RPM_PER_RAD_S
    p_elec = true_p_elec_w(speed_rpm, torque_nm, theta_c, model)
    return p_elec - omega * np.asarray(torque_nm, dtype=float) - fan_power_w(theta_c, model)


def theta_step(theta0_c, loss_w_, ambient_c, dt_s, model: LossModel = DEFAULT_MODEL):
    """Winding temperature after ``dt_s`` of constant loss (exact first-order solution).

    Parameters
    ----------
    theta0_c : float or array
        Temperature at the start [degC].
    loss_w_ : float or array
        Heat input, held constant [W].
    ambient_c : float
        Ambient temperature [degC].
    dt_s : float or array
        Elapsed time [s].
    model : LossModel
        Supplies ``r_th_k_per_w`` and ``tau_th_s``.

    Returns
    -------
    float or numpy.ndarray
        Temperature after ``dt_s`` [degC].
    """
    theta_ss = ambient_c + model.r_th_k_per_w * loss_w_
    return theta_ss + (theta0_c - theta_ss) * np.exp(-np.asarray(dt_s) / model.tau_th_s)


def quadratic_design(speed_rpm, torque_nm) -> np.ndarray:
    """Design matrix of the paper's four terms ``[1, n^2, T^2, n T]`` (paper eq. 4)."""
    n = np.asarray(speed_rpm, dtype=float)
    t = np.asarray(torque_nm, dtype=float)
    return np.column_stack([np.ones_like(n), n**2, t**2, n * t])


def fit_quadratic(speed_rpm, torque_nm, p_elec_w) -> tuple[np.ndarray, np.ndarray]:
    """OLS fit of the paper's quadratic; returns ``(coefficients, residuals [W])``."""
    x = quadratic_design(speed_rpm, torque_nm)
    y = np.asarray(p_elec_w, dtype=float)
    coef = np.linalg.lstsq(x, y, rcond=None)[0]
    return coef, y - x @ coef


def calibrate_core(evaluate, model: LossModel, target=PAPER_QUADRATIC, *, iterations=30,
                   rtol=1e-9) -> LossModel:
    """Adjust the core quadratic until the OLS fit of the campaign returns ``target``.

    Broyden's method on the relative coefficients ``core / target``; the fit moves
    almost one-for-one with the core (the thermal feedback through the losses is
    weak), so the identity is the starting Jacobian and a few iterations suffice.

    Parameters
    ----------
    evaluate : callable
        ``evaluate(model) -> (speed_rpm, torque_nm, p_elec_w)`` of the campaign's
        operating points under ``model`` (it reruns the thermal history, which
        depends on the losses and so on the core).
    model : LossModel
        Starting model.
    target : sequence of 4 float
        Quadratic the fit must return (rpm convention).
    iterations : int
        Maximum iterations.
    rtol : float
        Stop when every fitted coefficient is within ``rtol`` of its target.

    Returns
    -------
    LossModel
        The calibrated model.
    """
    target = np.asarray(target, dtype=float)

    def mismatch(x):
        coef, _ = fit_quadratic(*evaluate(model.with_core(x * target)))
        return coef / target - 1.0

    x = model.core / target
    f = mismatch(x)
    jac = np.eye(4)
    for _ in range(iterations):
        if np.all(np.abs(f) < rtol):
            break
        dx = -np.linalg.solve(jac, f)
        x_new = x + dx
        f_new = mismatch(x_new)
        jac = jac + np.outer(f_new - f - jac @ dx, dx) / (dx @ dx)
        x, f = x_new, f_new
    return model.with_core(x * target)
