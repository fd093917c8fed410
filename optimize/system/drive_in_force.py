"""The drive in force: which drive flies a system, its rating and its losses.

A system file's ``[drive]`` (docs/system_file.md) states the drive's rating and
where its losses come from. :func:`drive_in_force` resolves both into one
:class:`kernel.drive.Drive` that carries its losses (``Drive.power_model``), and says how in
a :class:`DriveResolution`:

- the **losses** (a power model file): ``--drive-model`` when given, else the
  file's ``losses`` key (``"paper"`` or a ``power_model.json`` path relative to
  the system file), else ``fit_out/power_model.json`` of ``bench fit`` when it
  exists, else the shipped paper model;
- the **drive** (:class:`kernel.drive.Drive`): the file's ``[drive]``, a rating key
  it leaves out from the power model's own rating (said so, in its ``source``);
- how the losses are **carried** to the rating: ``scaling = "similarity"``
  (:func:`optimize.model.drivetrain.carry_power_model` with the speed ratio ``k_n`` of
  the speed ratings, the corners of their constant-torque regions (the base speed of a
  system drive with a constant-power envelope, else its speed limit), and the torque
  ratio ``k_T`` of the nominal torques, nominal power over that speed, so ``k_n k_T`` is
  the ratio of nominal powers), ``"similarity-ie3"`` (the same, the losses per unit of
  rating moved as the IEC 60034-30-1 IE3 class moves between the two nominal powers:
  :func:`optimize.system.drive_power_check.rating_loss_ratio`) or
  ``"none"`` (the model as it is). Without the key a model whose rating differs
  from the system's by more than :data:`RATING_RATIO_LIMIT` in speed, torque or
  nominal power is refused (exit 2) naming the key.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from kernel.drive import DRIVE_KEYS, Drive
from kernel.errors import InputError
from optimize.system.drive_power_check import (
    efficiency_assumption,
    efficiency_law,
    power_check,
    rating_loss_ratio,
)

#: ``[drive] losses`` value naming the shipped paper model
LOSSES_PAPER = "paper"
#: the ``[drive] scaling`` value whose carried losses follow the IE3 class with rating
SCALING_IE3 = "similarity-ie3"
#: a power model whose speed or torque rating differs from the system's by more than this
#: factor is not used without a ``[drive] scaling`` key
RATING_RATIO_LIMIT = 1.5


@dataclass(frozen=True)
class DriveResolution:
    """How the drive in force was resolved (:func:`drive_in_force`): where its losses come
    from and how they were carried to its rating. The drive itself, its rating, envelope
    and losses, is the :class:`kernel.drive.Drive` beside it.

    Attributes
    ----------
    model_path : Path
        The power model file the losses were read from.
    losses_note : str
        Why that file.
    speed_ratio, torque_ratio : float or None
        The similarity law's ratios when carried, else None.
    loss_ratio : float
        The carried losses over the similarity law's at corresponding points (1: the base
        drive's efficiency kept; ``scaling = "similarity-ie3"``: the IE3 class's ratio).
    envelope_note : str
        Said when the power model's rating states a torque-speed envelope that the
        system file does not (the OCP flies the system file's), else empty.
    checks : tuple of str
        What the rating and the carried losses assume that a real machine would not
        (:mod:`optimize.system.drive_power_check`): printed, recorded, reported.
    """

    model_path: Path
    losses_note: str
    speed_ratio: float | None = None
    torque_ratio: float | None = None
    envelope_note: str = ""
    checks: tuple[str, ...] = ()
    loss_ratio: float = 1.0

    @property
    def carried(self) -> bool:
        """Whether the losses were carried to the rating by the similarity law."""
        return self.speed_ratio is not None

    def lines(self, drive: Drive) -> list[str]:
        """What ``bench optimize`` prints about the drive in force ``drive``."""
        out = [f"drive in force: {drive.line().removeprefix('drive: ')}",
               f"drive losses: {self.model_path} ({self.losses_note})"]
        if self.carried:
            losses = (f", losses x{self.loss_ratio:.3g} by the IE3 class"
                      if self.loss_ratio != 1.0 else "")
            out.append(f"drive losses carried to this rating by the similarity law "
                       f"(speed x{self.speed_ratio:.4g}, torque x{self.torque_ratio:.4g}"
                       f"{losses}; docs/system_file.md)")
        return (out + ([self.envelope_note] if self.envelope_note else [])
                + [f"note: {c}" for c in self.checks])

    def record(self, drive: Drive) -> dict:
        """The manifest's ``drive`` record of the drive in force ``drive``."""
        return {"losses_path": str(self.model_path),
                "losses_note": self.losses_note, "speed_ratio": self.speed_ratio,
                "torque_ratio": self.torque_ratio, "loss_ratio": self.loss_ratio,
                "model_sha256": drive.power_model.sha256,
                "checks": list(self.checks)}


def loss_model_path(system: Any, override: Path | None = None,
                    fit_default: Path | None = None) -> tuple[Path, str]:
    """The power model file that gives the losses, and why (see the module docstring)."""
    from optimize.paper_model import PAPER_MODEL_PATH

    if override is not None:
        return Path(override), "--drive-model"
    losses = system.drive.losses
    if losses == LOSSES_PAPER:
        return PAPER_MODEL_PATH, f"the shipped paper model, [drive] losses of {system.path}"
    if losses is not None:
        path = Path(losses)
        if not path.is_absolute():
            path = Path(system.path).parent / path
        return path, f"[drive] losses of {system.path}"
    if fit_default is not None and Path(fit_default).is_file():
        return Path(fit_default), f"from bench fit; {system.path} names no [drive] losses"
    return PAPER_MODEL_PATH, (f"the shipped paper model: no {fit_default} found and "
                              f"{system.path} names no [drive] losses"
                              if fit_default is not None else "the shipped paper model")


def complete_drive(system: Any, model: Any, model_path: Path | str) -> Drive:
    """The system's ``[drive]`` in force: a rating key it leaves out from the power model's
    rating (its nominal power from the model's own), ``source`` saying which: the system
    file's name, ``[drive]``, the file's own ``source`` and where a borrowed key came from
    (:func:`portable_name`).

    Raises
    ------
    InputError
        When a rating key is in neither, or the rating is not one (naming the key).
    """
    d = system.drive
    given = getattr(model, "drive", None)
    values, borrowed = {}, []
    for key in DRIVE_KEYS:
        own = getattr(d, key)
        # the model's nominal power is its rating's where it states one (one value)
        theirs = model.nominal_power_w if key == "nominal_power_w" else getattr(given, key, None)
        if own is not None:
            values[key] = own
        elif theirs is not None:
            values[key] = float(theirs)
            borrowed.append(key)
        else:
            raise InputError(system.path, f"[drive] {key}: not in the system file and not in "
                             f"the power model's rating ({model_path})",
                             expected=f"{key} in [drive] of the system file")
    folder = Path(system.path).parent
    source = f"{Path(system.path).name} [drive]" + (f": {d.source}" if d.source else "")
    if borrowed:
        source += f"; {', '.join(borrowed)} from {portable_name(model_path, folder)}"
    drive = dataclasses.replace(d, **values, source=source)
    problem = drive.rating_problem()
    if problem is not None:
        raise InputError(system.path, "[drive]: {} = {}: {} expected".format(*problem))
    return drive.floats()


def portable_name(path: Path | str, folder: Path | str) -> str:
    """How a drive's ``source`` names a file: its path relative to ``folder`` (the system
    file's) when it lies within it, else its name; never where the checkout or the user's
    folder lies, so that a carried model's SHA-256 (and every stored solve's key that holds
    it) stays when the files move together."""
    path = Path(path)
    try:
        return path.resolve().relative_to(Path(folder).resolve()).as_posix()
    except ValueError:
        return path.name


def _factor(ratio: float) -> float:
    """How many times larger or smaller: ``max(ratio, 1 / ratio)``."""
    return max(ratio, 1.0 / ratio)


def drive_in_force(system: Any, override: Path | None = None, fit_default: Path | None = None,
                   drive_model: Any = None) -> tuple[Drive, DriveResolution]:
    """Resolve the drive a system flies with (see the module docstring).

    Parameters
    ----------
    system : optimize.system.system.System
    override : Path, optional
        ``--drive-model``: the losses' file, whatever the system file says.
    fit_default : Path, optional
        ``bench fit``'s output, used when it exists and the file names no losses.
    drive_model : fitting.power_model.PowerModel, optional
        The losses already loaded (from ``override``; for library callers).

    Returns
    -------
    drive : kernel.drive.Drive
        The system's ``[drive]`` in force, every rating key stated (a key the file leaves
        out from the power model's rating), its ``source`` saying where they come from
        (:func:`complete_drive`), with its losses (:attr:`kernel.drive.Drive.power_model`:
        the power model at this rating, carried when scaled, with the winding's thermal
        model when it has one).
    resolution : DriveResolution
        Where the losses come from and how they were carried.

    Raises
    ------
    InputError
        A rating key in neither file, a model that cannot be read, or ratings that
        differ by more than :data:`RATING_RATIO_LIMIT` without ``[drive] scaling``.
    """
    from fitting.model_file import load_power_model

    model = drive_model
    if model is not None:
        path, note = Path(override or "<power model>"), "given"
    else:
        path, note = loss_model_path(system, override, fit_default)
        model = load_power_model(path)
    drive = complete_drive(system, model, path)
    base = getattr(model, "drive", None)
    found = DriveResolution(path, note, envelope_note=unflown_envelope(system, base, path),
                            checks=tuple(c for c in (power_check(drive),) if c))
    scaling = drive.scaling
    if scaling == "none":
        return drive.with_losses(model), found
    if base is None:
        if scaling is not None:
            raise InputError(system.path, f'[drive] scaling = "{scaling}": the power model '
                             f"{path} states no rating to carry its losses from",
                             expected='a power model with a "drive" rating, or scaling = "none"')
        return drive.with_losses(model), found
    ratios = {k: getattr(drive, k) / float(getattr(base, k)) for k in DRIVE_KEYS}
    if scaling is None:
        _check_ratios(system, drive, base, path, ratios, override)
        return drive.with_losses(model), found
    return _carried(drive, model, base, ratios, found)


def _check_ratios(system: Any, drive: Drive, base: Drive, path: Path, ratios: dict,
                  override: Path | None) -> None:
    """Refuse a power model whose rating differs from the drive's by more than
    :data:`RATING_RATIO_LIMIT` when the system file says not how to carry its losses."""
    if max(_factor(r) for r in ratios.values()) <= RATING_RATIO_LIMIT:
        return
    if override is not None:
        raise InputError(  # the user's --drive-model is the file to look at
            path,
            f"its drive rating ({base.rating_text()}) differs from the drive of the "
            f"system {system.path} ({drive.rating_text()}) by more than "
            f"x{RATING_RATIO_LIMIT:g}",
            column="drive", expected="--drive-model: a power model of the system's drive, "
            'or [drive] scaling = "similarity" or "none" in the system file')
    raise InputError(
        system.path,
        f"[drive]: this drive ({drive.rating_text()}) differs from the rating of its "
        f"power model {path} ({base.rating_text()}) by more than "
        f"x{RATING_RATIO_LIMIT:g}, and the file does not say how to carry the losses "
        "over",
        expected='[drive] scaling = "similarity" (carry the losses to this rating, '
                 'docs/system_file.md) or scaling = "none" (use them as they are)')


def _carried(drive: Drive, model: Any, base: Drive, ratios: dict,
             found: DriveResolution) -> tuple[Drive, DriveResolution]:
    """The drive with the losses of ``model`` (rated ``base``) carried to its rating by the
    similarity law of its ``scaling``, and the resolution saying so."""
    from optimize.model.drivetrain import carry_power_model

    # the machine's size: the ratio of the corners of the constant-torque regions (a base
    # speed, else the speed limit) and of nominal torques (nominal power / that speed)
    k_n = drive.corner_rpm() / base.corner_rpm()
    k_t = ratios["nominal_power_w"] / k_n
    lam, size_line = 1.0, efficiency_assumption(ratios["nominal_power_w"])
    if drive.scaling == SCALING_IE3:
        lam = rating_loss_ratio(base.nominal_power_w, drive.nominal_power_w)
        size_line = efficiency_law(base.nominal_power_w, drive.nominal_power_w)
    carried = carry_power_model(model, k_n, k_t, drive=drive.rating_part(),
                                name=f"{model.name} carried to "
                                     f"{drive.rating_text(power=False)}", loss_ratio=lam)
    return drive.with_losses(carried), dataclasses.replace(
        found, speed_ratio=k_n, torque_ratio=k_t, loss_ratio=lam,
        checks=(*found.checks, *(c for c in (size_line,) if c)))


def unflown_envelope(system: Any, model_drive: Drive | None, path: Path) -> str:
    """A line when the power model's rating (its campaign's ``drive.toml``) states a
    torque-speed envelope and the system file's ``[drive]`` states none, else ``""``."""
    stated = list(model_drive.envelope) if model_drive is not None else []
    if not stated or system.drive.has_envelope():
        return ""
    return (f"the power model's drive rating ({path}) states a torque-speed envelope "
            f"({', '.join(stated)}) that the system file's [drive] does not: not flown; state "
            "base_speed_rpm or envelope_speed_rpm/envelope_torque_nm in [drive] (at the "
            "power model's shaft) to fly it")
