"""Periodic pumping-cycle optimal control problem (paper section IV, eq. 5), built.

:func:`build_ocp` puts the kite's parts together once per (options, drive model):
the formulation (:mod:`optimize.problem.formulation`: DAE, path constraints,
periodicity, objective, bounds, from the system and its drive), the transcription
(:mod:`optimize.problem.transcriptions`: Radau collocation into one scaled NLP)
and the options (:mod:`optimize.problem.options`). :func:`assemble` does the
same for any formulation (:class:`optimize.problem.interface.CycleFormulation`).
The NLP is solved for any scenario by changing only NLP parameters (wind speed,
objective weights by cycle-average name, homotopy weights, reference trajectory)
and variable/constraint bounds (drive limits, fixed period, fictitious forces
switched off); :mod:`optimize.solve` runs the solvers.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from typing import Any

import casadi as ca
import numpy as np

from kernel.drive import DriveModel
from kernel.errors import InputError
from kernel.sections import bound_keys
from optimize.model.dae import Dae
from optimize.model.kite_model import KiteDae
from optimize.model.thermal import WindingThermal
from optimize.problem.collocation import Collocation, radau
from optimize.problem.formulation import Formulation
from optimize.problem.guess import LoopBounds, LoopGuess, start_loop
from optimize.problem.interface import CycleFormulation, weight_param
from optimize.problem.kite_part import body_rate_limit_rad_s
from optimize.problem.options import OcpOptions
from optimize.problem.part import Part
from optimize.problem.part_sections import section_parts
from optimize.problem.parts import kite_parts
from optimize.problem.scaling import Scales, system_scales
from optimize.problem.transcriptions import method_of
from optimize.problem.transcriptions.structure import Layout, Transcription

log = logging.getLogger(__name__)

#: the inputs whose values bound each NLP row or variable, named when its lower bound is
#: above its upper one (:func:`crossed_bounds`); others are named by the row or variable.
#: ``{bound}``: the ``[bounds]`` key of that bound (:func:`kernel.sections.bound_keys`)
BOUND_INPUTS = {
    "torque": "{torque_limit} against {tension_min} (the tension floor's "
              "torque on the drum)",
    "airspeed": "[bounds] min_airspeed_m_s, max_airspeed_m_s",
    "alpha": "[aero] alpha_min_deg, alpha_max_deg",
    "beta": "[aero] beta_min_deg, beta_max_deg",
    "line_angle": "{line_angle_limit}",
    "tether_force": "the tether-force limit against {tension_min}",
    "rms_torque": "[drive] continuous_torque_nm",
    "p_elec": "[drive] max_p_elec_w",
    "envelope": "[drive] base_speed_rpm or envelope_speed_rpm, envelope_torque_nm",
    "winding_temperature": "[drive] max_winding_temperature_c, ambient_temperature_c",
    "period_s": "[bounds] period_min_s, period_max_s",
    "l_m": "[bounds] tether_length_min_m, tether_length_max_m",
}


class _BoundKeys(dict):
    """``[bounds] key`` by bound name (a name without a key: itself)."""

    def __missing__(self, bound: str) -> str:
        return bound


def crossed_bounds(layout: Layout, bounds: tuple[np.ndarray, ...], system: Any = None
                   ) -> str | None:
    """Which rows and variables of the NLP have a lower bound above their upper one
    (``bounds``: ``lbw, ubw, lbg, ubg``), and the inputs those bounds come from (the keys of
    ``system``'s ``[bounds]``); None when none does (the solver would stop on an assertion
    without naming them)."""
    lbw, ubw, lbg, ubg = bounds
    names = []
    for where, lo, hi in ((layout.variables, lbw, ubw), (layout.rows, lbg, ubg)):
        crossed = np.flatnonzero(np.asarray(lo) > np.asarray(hi))
        if crossed.size:
            names += [n for n, idx in where.items()
                      if np.intersect1d(np.ravel(idx), crossed).size]
    if not names:
        return None
    keys = _BoundKeys() if system is None else _BoundKeys(
        {b: f"[{name}] {k}" for name in ("bounds", "drive")
         for b, k in bound_keys(getattr(system, name)).items()})
    said = "; ".join(f"{n} ({BOUND_INPUTS[n].format_map(keys)})" if n in BOUND_INPUTS else n
                     for n in names)
    return (f"the NLP's bounds cross (lower above upper), so no point satisfies them: {said}; "
            "those inputs contradict each other")

Bounds = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]


@dataclass
class Ocp:
    """A built OCP: formulation, transcribed NLP and its base bounds.

    Build the kite's with :func:`build_ocp` (any formulation's with :func:`assemble`);
    solve it with :func:`optimize.solve.solve.solve` or :func:`optimize.solve.starts.cold.start`
    (the kite's) or :func:`optimize.solve.nlp_solver.run` (any). Solvers created for it are
    cached in ``solvers`` (:mod:`optimize.solve.nlp_solver`).
    """

    options: OcpOptions
    formulation: CycleFormulation
    coll: Collocation
    transcription: Transcription
    build_time_s: float
    loop: LoopGuess | None = None
    system: Any = None
    solvers: dict = field(default_factory=dict, repr=False)
    _g_fn: ca.Function | None = field(default=None, repr=False)

    @property
    def dae(self) -> Dae:
        """The model (the kite DAE for :func:`build_ocp`)."""
        return self.formulation.dae

    @property
    def drive_model(self) -> DriveModel:
        """The drive's electrical power model."""
        return self.formulation.drive_model

    @property
    def scales(self) -> Scales:
        """Scale factors of the variables and rows."""
        return self.formulation.scales

    @property
    def layout(self) -> Layout:
        """Index bookkeeping of the NLP vectors."""
        return self.transcription.layout

    @property
    def nlp(self) -> dict:
        """The CasADi NLP ``{"x", "p", "f", "g"}`` (scaled)."""
        return self.transcription.nlp

    @property
    def n_intervals(self) -> int:
        """Collocation intervals per period."""
        return self.options.discretization.n_intervals

    def constraint_values(self, w_scaled: np.ndarray, p: np.ndarray) -> np.ndarray:
        """Scaled constraint vector ``g(w, p)`` (for residual checks)."""
        if self._g_fn is None:
            self._g_fn = ca.Function("g", [self.nlp["x"], self.nlp["p"]], [self.nlp["g"]])
        return np.asarray(self._g_fn(w_scaled, p)).ravel()

    def params(
        self,
        parameters: Mapping[str, float] | float | None,
        weights: dict[str, float] | None = None,
        w_reg: float | None = None,
        w_track: float = 0.0,
        w_fict: float = 0.0,
        x_ref: np.ndarray | None = None,
    ) -> np.ndarray:
        """NLP parameter vector.

        Parameters
        ----------
        parameters : dict of float, float or None
            The model's parameters by name (:attr:`CycleFormulation.parameters`; a
            scenario's :attr:`optimize.problem.scenario.Scenario.parameters`, the kite's
            reference wind speed [m/s]); a number: the value of the model's only one;
            None: a model without parameters.
        weights : dict, optional
            Objective weight per cycle average, by name (``{"p_elec_w": 1.0}``;
            :attr:`optimize.kinds.Kind.weights`) [per objective scale]; the others 0.
        w_reg : float, optional
            Regularization weight [per objective scale]; defaults to the
            discretization's ``regularization_w`` over the objective scale.
        w_track, w_fict : float
            Homotopy weights: state tracking and fictitious-force penalty.
        x_ref : ndarray (NX, N d + 1), optional
            Tracking reference at the state grid points [SI].
        """
        lay = self.layout
        if w_reg is None:
            w_reg = (self.options.discretization.regularization_w
                     / self.formulation.objective_scale)
        values = {**self.model_parameters(parameters), "w_reg": w_reg, "w_track": w_track,
                  "w_fict": w_fict}
        for average, weight in (weights or {}).items():
            if weight_param(average) not in lay.params:
                raise ValueError(f"no cycle average {average!r} to weight; the objective "
                                 f"weights {', '.join(self.formulation.objective_averages)}")
            values[weight_param(average)] = weight
        p = np.zeros(lay.n_p)
        for name, value in values.items():
            p[lay.params[name]] = value
        if x_ref is not None:
            p[lay.i_p_ref] = x_ref / self.scales.state[:, None]
        return p

    def model_parameters(self, parameters: Mapping[str, float] | float | None
                         ) -> dict[str, float]:
        """The model's parameters by name, every one given (see :meth:`params`)."""
        names = tuple(self.formulation.parameters)
        if parameters is None:
            parameters = {}
        elif not isinstance(parameters, Mapping):
            if len(names) != 1:
                raise ValueError(f"one number for the model's parameters {names}")
            parameters = {names[0]: parameters}
        if set(parameters) != set(names):
            raise ValueError(f"the model's parameters are {names}, got {tuple(parameters)}")
        return {name: float(parameters[name]) for name in names}

    def bounds(self, drive_limits: bool, fix_fictitious: bool, period_s: float | None) -> Bounds:
        """Scaled ``lbx, ubx, lbg, ubg`` for a configuration.

        ``drive_limits`` applies the drive's limits (the formulation's limited
        bounds); ``period_s`` fixes the period when given; ``fix_fictitious`` pins
        the fictitious forces at zero (the physical model).

        Raises
        ------
        ValueError
            Some bounds cross (:func:`crossed_bounds`, naming the inputs).
        """
        tr, lay = self.transcription, self.layout
        base = tr.limited if drive_limits else (tr.lbw, tr.ubw, tr.lbg, tr.ubg)
        lbw, ubw, lbg, ubg = (a.copy() for a in base)
        if fix_fictitious:
            lbw[lay.i_f.ravel()] = 0.0
            ubw[lay.i_f.ravel()] = 0.0
        if period_s is not None:
            # fix the first copy only: the copies follow through their equality rows
            # (fixing all would leave those rows with an empty Jacobian)
            lbw[lay.i_period[0]] = ubw[lay.i_period[0]] = period_s / self.scales.period_s
        why = crossed_bounds(lay, (lbw, ubw, lbg, ubg), self.system)
        if why is not None:
            raise ValueError(why)
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
        w /= lay.scale_w
        if lay.complete is not None:  # copies and running integrals of the stage layout
            w = np.asarray(lay.complete(w)).ravel()
        return w

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
    system: Any = None, parts: tuple[Part, ...] = (),
) -> Ocp:
    """Build the scaled collocation NLP once for given options and drive model.

    Parameters
    ----------
    dae : KiteDae
        The kite model (:func:`optimize.model.kite_model.kite_dae`).
    drive_model : DriveModel
        Electrical power model of the drive (``fitting.power_model.PowerModel``).
    options : OcpOptions, optional
        Discretization and solver; defaults to :class:`OcpOptions`.
    system : optimize.system.system.System
        The system ``dae`` comes from, with the drive in force
        (:meth:`optimize.system.system.System.in_force`): the parts read their bounds from
        its sections; recorded on the OCP (the stored initial guess is accepted only for
        its own system). The parts of its part sections (``system.part_inputs``,
        :data:`optimize.problem.part_sections.PART_SECTIONS`) follow the kite's own.
    parts : tuple of Part
        Parts added after those.

    Returns
    -------
    Ocp
        The NLP with its layout and base bounds; solvers are created lazily.
    """
    t0 = time.perf_counter()
    o = options or OcpOptions()
    loop, scales, own = _model(dae, drive_model, o, system)
    form = Formulation((*own, *parts), o.discretization, scales)
    return assemble(form, o, loop=loop, system=system, started=t0)


def model_parts(dae: KiteDae, drive_model: DriveModel, options: OcpOptions | None = None,
                system: Any = None, parts: tuple[Part, ...] = ()) -> tuple[Part, ...]:
    """The parts :func:`build_ocp` builds its OCP of, without the NLP (what a sweep's
    tables hold, :func:`optimize.problem.part.trajectory_columns`); same arguments."""
    return (*_model(dae, drive_model, options or OcpOptions(), system)[2], *parts)


def _model(dae: KiteDae, drive_model: DriveModel, o: OcpOptions, system: Any
           ) -> tuple[LoopGuess, Scales, tuple[Part, ...]]:
    """The start loop, the scales and the parts of ``system`` (with the drive in force):
    the kite's (:func:`kite_parts`), then those of the system's part sections
    (:func:`section_parts`).

    Raises
    ------
    TypeError
        No system: the parts' bounds are its sections'.
    """
    if system is None:
        raise TypeError("build_ocp needs the system whose sections bound the OCP (a System "
                        "with the drive in force: optimize.resolve.resolve(...).system)")
    lim, drive = system.bound_values(), system.drive
    loop = start_loop(dae.kite, dae.coeffs, dae.wind, system.aero.alpha_max_deg,
                      LoopBounds(lim["airspeed_min"], (lim["period_min"], lim["period_max"]),
                                 (lim["tether_length_min"], lim["tether_length_max"]),
                                 lim["ground_clearance"], lim["airspeed_max"],
                                 body_rate_limit_rad_s(system.bounds)))
    scales = system_scales(dae.kite, loop, drive)
    own = kite_parts(dae, drive_model, system, scales, loop, winding_thermal(drive_model, drive))
    return loop, scales, (*own, *section_parts(system.part_inputs, dae, scales))


def thermal_line(drive_model: DriveModel, drive: Any, source: Any = None) -> str:
    """One line: how the drive's continuous rating enters the OCP (winding temperature or
    RMS torque), and why.

    Raises
    ------
    InputError
        The winding limit is not above the ambient temperature in force (naming
        ``source``, the system file, and the key).
    """
    try:
        thermal = winding_thermal(drive_model, drive)
    except ValueError as exc:
        raise InputError(source, str(exc), column="max_winding_temperature_c",
                         expected="a winding limit above the ambient temperature "
                                  "([drive] ambient_temperature_c, else the one the "
                                  "thermal model was fitted with)") from exc
    limit = drive.max_winding_temperature_c
    if thermal is not None:
        return (f"continuous rating: winding temperature <= {thermal.max_c:g} degC at "
                f"{thermal.ambient_c:.4g} degC ambient, a periodic state of the cycle "
                f"(thermal model of {len(thermal.ladder)} node{'s' * (len(thermal.ladder) > 1)}: "
                f"r_th {thermal.r_th_k_per_w:.4g} K/W, tau_th {thermal.tau_th_s:.4g} s), "
                "in place of the RMS-torque row")
    rms = ("RMS torque <= " + f"{drive.rms_torque_limit_nm:g} N m"
           if drive.rms_torque_limit_nm is not None else "none stated")
    if limit is not None:
        return (f"continuous rating: {rms}; the winding limit {limit:g} degC is not applied: "
                "the power model has no thermal model (bench fit fits one from sessions "
                "that log the winding temperature)")
    if getattr(drive_model, "thermal", None) is not None:
        return (f"continuous rating: {rms}; the power model has a thermal model, "
                "[drive] max_winding_temperature_c would put the winding temperature in "
                "the cycle")
    return f"continuous rating: {rms}"


def winding_thermal(drive_model: DriveModel, drive: Any) -> WindingThermal | None:
    """The winding's thermal model in the OCP: when the drive (its ``[drive]`` in force)
    has a thermal rating (``max_winding_temperature_c``) and its power model a thermal
    model; else None (the RMS-torque row stands for the continuous rating)."""
    thermal = getattr(drive_model, "thermal", None)
    if drive.max_winding_temperature_c is None or thermal is None:
        return None
    return WindingThermal.of(drive_model, drive.max_winding_temperature_c,
                             drive.ambient_temperature_c)


def assemble(form: CycleFormulation, options: OcpOptions, loop: LoopGuess | None = None,
             system: Any = None, started: float | None = None) -> Ocp:
    """Transcribe any formulation for ``options``' solver and discretization.

    Parameters
    ----------
    form : CycleFormulation
        What is optimized (:mod:`optimize.problem.interface`).
    options : OcpOptions
        Discretization and solver (its limits are the formulation's business).
    loop : LoopGuess, optional
        The kite's start loop (the homotopy's guess); ``None`` for other models.
    system : optimize.system.system.System, optional
        Recorded on the OCP.
    started : float, optional
        ``time.perf_counter()`` when the build began (default: now).
    """
    t0 = time.perf_counter() if started is None else started
    disc = options.discretization
    coll = radau(disc.degree)
    tr = method_of(options.solver).transcribe(form, disc, coll, options.solver)
    ocp = Ocp(options=options, formulation=form, coll=coll, transcription=tr,
              build_time_s=0.0, loop=loop, system=system)
    ocp.build_time_s = time.perf_counter() - t0
    log.info("built OCP (%s layout): %d variables, %d constraints, N=%d, degree %d in %.1f s",
             tr.layout.name, tr.layout.n_w, tr.layout.n_g, disc.n_intervals, disc.degree,
             ocp.build_time_s)
    return ocp


def twin(ocp: Ocp, solver: str) -> Ocp:
    """The same problem transcribed for another solver (built once, cached on ``ocp``)."""
    if ocp.options.solver.solver == solver:
        return ocp
    key = ("twin", solver)
    if key not in ocp.solvers:
        other = assemble(ocp.formulation, ocp.options.replace(solver={"solver": solver}),
                         loop=ocp.loop, system=ocp.system)
        ocp.solvers[key] = other
    return ocp.solvers[key]


def on_mesh(ocp: Ocp, n_intervals: int, degree: int) -> Ocp:
    """The same problem on ``n_intervals`` x ``degree`` (``ocp`` itself when that is its
    mesh; built once, cached on ``ocp``), e.g. the stored initial guess's own mesh."""
    if (n_intervals, degree) == (ocp.n_intervals, ocp.coll.degree):
        return ocp
    key = ("mesh", n_intervals, degree)
    if key not in ocp.solvers:
        options = ocp.options.replace(discretization={"n_intervals": n_intervals,
                                                      "degree": degree})
        form = replace(ocp.formulation, discretization=options.discretization)
        ocp.solvers[key] = assemble(form, options, loop=ocp.loop, system=ocp.system)
    return ocp.solvers[key]


def grid_times(ocp: Ocp, period_s: float) -> np.ndarray:
    """Times [s] of the ``N d + 1`` state grid points for a period."""
    n, coll = ocp.n_intervals, ocp.coll
    h = period_s / n
    t = [0.0] + [h * (k + coll.tau[j]) for k in range(n) for j in range(1, coll.degree + 1)]
    return np.array(t)
