"""The parts of the kite's cycle OCP, in order (:mod:`optimize.problem.part`).

The kite first (its variables and quantities are what the others read), then the
drivetrain and the drive, then the tether's mass and drag when the system gives them,
then the winding temperature when the drive has a thermal rating and its power model a
thermal model. A new part is one more entry here, or an
extra part handed to :func:`optimize.problem.ocp.build_ocp`, or, with inputs of its own,
its section of the system file registered in
:data:`optimize.problem.part_sections.PART_SECTIONS`.
"""

from __future__ import annotations

from typing import Any

from kernel.drive import DriveModel
from optimize.model.drivetrain import Drivetrain
from optimize.model.kite_model import KiteDae
from optimize.model.thermal import WindingThermal
from optimize.problem.drive_part import DrivePart
from optimize.problem.guess import LoopGuess
from optimize.problem.kite_part import KitePart
from optimize.problem.part import Part
from optimize.problem.scaling import Scales
from optimize.problem.tether_part import TetherPart
from optimize.problem.thermal_part import ThermalPart


def kite_parts(dae: KiteDae, drive_model: DriveModel, system: Any, scales: Scales,
               loop: LoopGuess, thermal: WindingThermal | None = None) -> tuple[Part, ...]:
    """The kite, its drive and (with ``thermal``) the winding temperature.

    Parameters
    ----------
    dae : KiteDae
    drive_model : DriveModel
        Electrical power model of the drive.
    system : optimize.system.system.System
        The system with the drive in force (:meth:`optimize.system.system.System.in_force`):
        the parts' inputs, their bounds.
    scales : Scales
        The system's magnitudes (:func:`optimize.problem.scaling.system_scales`).
    loop : LoopGuess
        The kite's start loop.
    thermal : WindingThermal, optional
        The winding's thermal model and limit; it replaces the RMS-torque row.
    """
    rms = system.drive.rms_torque_limit_nm if thermal is None else None
    parts: tuple[Part, ...] = (
        KitePart(dae, system, scales, loop),
        DrivePart(Drivetrain.of(dae.kite), drive_model, system, scales, rms_torque_nm=rms),
    )
    if dae.tether.mass_kg_m > 0 or dae.tether.drag_elements > 0:
        parts = (*parts, TetherPart(dae, scales.force_n))
    return parts if thermal is None else (*parts, ThermalPart(thermal))
