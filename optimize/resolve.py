"""The one resolution of what a solve flies: the system with the drive in force in it
(its ``[drive]`` with the rating in force) and the OCP options.

``bench optimize`` (:func:`optimize.command.make_request`), ``bench size``
(:func:`energy.size_command.run_size`) and the Python API resolve their inputs here,
through optimize's front door (:mod:`optimize.door`).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from kernel.drive import Drive
from optimize.problem.ocp import thermal_line
from optimize.problem.options import OcpOptions
from optimize.system.drive_in_force import DriveResolution, drive_in_force
from optimize.system.system import System
from optimize.system.system_file import load_system


@dataclass(frozen=True)
class Setup:
    """A system, its drive in force and the OCP options of its solves.

    Attributes
    ----------
    system : optimize.system.system.System
        Kite, tether, winch, wind and bounds, with the drive in force
        (:meth:`optimize.system.system.System.in_force`): the OCP's bounds.
    drive : kernel.drive.Drive
        The drive in force: its rating, envelope and its losses at that rating
        (:attr:`kernel.drive.Drive.power_model`, with the winding's thermal model).
    resolution : optimize.system.drive_in_force.DriveResolution
        Where the losses come from and how they were carried to the rating.
    options : optimize.problem.options.OcpOptions
        Discretization and solver.
    """

    system: System
    drive: Drive
    resolution: DriveResolution
    options: OcpOptions

    def thermal_line(self) -> str:
        """How the drive's continuous rating enters the OCP (winding temperature or RMS
        torque), and why (:func:`optimize.problem.ocp.thermal_line`)."""
        return thermal_line(self.drive.power_model, self.system.drive, self.system.path)


def resolve(system: Path | str | System | None = None, drive_model: Any = None, *,
            fit_default: Path | str | None = None, options: OcpOptions | None = None,
            model_path: Path | None = None) -> Setup:
    """Resolve the system, the drive in force and the OCP options.

    Parameters
    ----------
    system : Path or System, optional
        A system file or a loaded system; default the shipped ``highwind.toml``.
    drive_model : Path or PowerModel, optional
        The drive's losses (``--drive-model``, or a model object), overriding the system
        file's (:func:`optimize.system.drive_in_force.drive_in_force`).
    fit_default : Path, optional
        ``bench fit``'s model, used when it exists and neither ``drive_model`` nor the system
        file names the losses.
    options : OcpOptions, optional
        Discretization and solver (default :class:`OcpOptions`).
    model_path : Path, optional
        Where a drive model object was read from (recorded with it).

    Raises
    ------
    InputError
        A system file or power model that cannot be read, or a drive that the system's
        ``[drive]`` cannot take (see :func:`drive_in_force`).
    """
    loaded = system if isinstance(system, System) else load_system(system)
    if drive_model is None or isinstance(drive_model, str | Path):
        drive, how = drive_in_force(loaded, None if drive_model is None else Path(drive_model),
                                    None if fit_default is None else Path(fit_default))
    else:
        drive, how = drive_in_force(loaded, model_path, drive_model=drive_model)
    return Setup(loaded.in_force(drive), drive, how, options or OcpOptions())
