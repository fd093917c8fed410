"""Power curves of the optimize stage: one per scenario kind, read from its files.

Reads ``optimize_out/summary.parquet`` and ``manifest.json`` (docs/schemas.md §5)
through their owner, :mod:`optimize.sweep_folder`; never imports the optimizer. A power
curve keeps the optimize sign convention (negative power = generated); the
energy functions turn it into delivered power ``-P``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from kernel.drive import Drive
from kernel.errors import InputError
from optimize.sweep_folder import read_sweep_folder, sweep_drive


@dataclass(frozen=True)
class PowerCurve:
    """Optimal cycle-average powers of one scenario kind over the wind grid.

    Attributes
    ----------
    kind : str
        Scenario kind, e.g. ``"elec-lim"``.
    objective : str
        ``"electrical"`` or ``"mechanical"``.
    drive_limits : bool
        Whether the drive limits applied.
    wind_speed_m_s : ndarray
        Wind speeds of the converged scenarios at the reference height [m/s], increasing.
    p_elec_w, p_mech_w : ndarray
        Cycle-average electrical / mechanical power [W] (negative = generated).
    period_s : ndarray
        Cycle period [s].
    peak_speed_rpm, peak_torque_nm : ndarray
        Largest |drum speed| [rpm] and drum torque [N m] of each cycle.
    scenarios : tuple of str
        Scenario names, one per wind speed.
    failed : tuple of (float, str)
        Wind speeds [m/s] whose solve failed and their status: not used, the
        curve is interpolated across them.
    cut_in_m_s : float or None
        Cut-in wind speed found by the optimize stage's bisection [m/s], or None.
    added : tuple of bool
        Per wind speed: solved by ``bench aep --refine`` (:mod:`energy.refine`), not by
        the sweep; empty means none.
    """

    kind: str
    objective: str
    drive_limits: bool
    wind_speed_m_s: np.ndarray
    p_elec_w: np.ndarray
    p_mech_w: np.ndarray
    period_s: np.ndarray
    peak_speed_rpm: np.ndarray
    peak_torque_nm: np.ndarray
    scenarios: tuple[str, ...]
    failed: tuple[tuple[float, str], ...] = ()
    cut_in_m_s: float | None = None
    added: tuple[bool, ...] = ()

    def power_w(self, quantity: str) -> np.ndarray:
        """``p_elec_w`` or ``p_mech_w`` by name (``"elec"`` / ``"mech"``)."""
        if quantity not in ("elec", "mech"):
            raise ValueError(f"quantity must be 'elec' or 'mech', got {quantity!r}")
        return self.p_elec_w if quantity == "elec" else self.p_mech_w


@dataclass(frozen=True)
class OptimizeRun:
    """What the energy stage needs from one ``bench optimize`` output folder."""

    folder: Path
    curves: dict[str, PowerCurve]
    manifest: dict
    summary: pd.DataFrame

    @property
    def drive_model_path(self) -> Path | None:
        """The power model file the sweep used (manifest ``drive_model.path``)."""
        path = (self.manifest.get("drive_model") or {}).get("path")
        return Path(path) if path else None

    @property
    def drive(self) -> Drive | None:
        """The ``[drive]`` in force the sweep flew (manifest ``sections.drive``), or None
        for an older sweep that records none
        (:func:`optimize.sweep_folder.sweep_drive`)."""
        return sweep_drive(self.manifest, self.folder)

    @property
    def drive_model_sha256(self) -> str | None:
        """``PowerModel.sha256`` of the sweep's model (manifest ``drive_model.model_sha256``)."""
        return (self.manifest.get("drive_model") or {}).get("model_sha256")


def read_optimize_run(folder: str | Path) -> OptimizeRun:
    """Read a ``bench optimize`` output folder into one :class:`PowerCurve` per kind.

    Raises
    ------
    InputError
        A missing file or column, a folder that is not the whole output of one
        run (:func:`kernel.output_folder.check_output_folder`); a kind with no
        converged scenario is kept out of ``curves`` (it is still in ``summary``).
    """
    folder = Path(folder)
    summary, manifest = read_sweep_folder(folder)
    cut_ins = {}
    for c in manifest.get("cut_in") or []:
        value = c.get("cut_in_m_s") if isinstance(c, dict) else None
        if c.get("status") == "found" and isinstance(value, int | float) and math.isfinite(value):
            cut_ins[c.get("kind")] = float(value)
    curves = {}
    for kind, rows in summary.groupby("kind", sort=False):
        rows = rows.sort_values("wind_speed_m_s")
        ok = rows[rows["success"].astype(bool)]
        if ok["wind_speed_m_s"].duplicated().any():
            raise InputError(folder / "summary.parquet", f"kind {kind}: a wind speed appears twice",
                             column="wind_speed_m_s")
        if ok.empty:
            continue
        first = ok.iloc[0]
        curves[str(kind)] = PowerCurve(
            kind=str(kind),
            objective=str(first["objective"]),
            drive_limits=bool(first["drive_limits"]),
            wind_speed_m_s=ok["wind_speed_m_s"].to_numpy(float),
            p_elec_w=ok["avg_p_elec_w"].to_numpy(float),
            p_mech_w=ok["avg_p_mech_w"].to_numpy(float),
            period_s=ok["period_s"].to_numpy(float),
            peak_speed_rpm=ok["peak_speed_rpm"].to_numpy(float),
            peak_torque_nm=ok["peak_torque_nm"].to_numpy(float),
            scenarios=tuple(ok["scenario"].astype(str)),
            failed=tuple((float(r.wind_speed_m_s), str(r.status))
                         for r in rows[~rows["success"].astype(bool)].itertuples()),
            cut_in_m_s=cut_ins.get(str(kind)),
        )
    return OptimizeRun(folder, curves, manifest, summary)
