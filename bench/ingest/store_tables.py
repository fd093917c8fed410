"""What a processed session hands to the store: its operating points and rejected windows
as tables of the store's schemas, its staged samples file and its manifest fields."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyarrow as pa

from bench.ingest import steady
from bench.ingest.session import Session
from bench.store.schema import POINTS_SCHEMA, REJECTED_SCHEMA, TEMPERATURE_COLUMNS


@dataclass
class SessionOutput:
    """What a processed session hands to the store.

    Parameters
    ----------
    points : pyarrow.Table
        Operating points (store points schema).
    rejected : pyarrow.Table
        Rejected windows.
    samples_path : Path or None
        Staged samples Parquet file (timeseries sessions).
    info : dict
        Manifest fields: clock offset/drift, instruments, counts.
    cycles : pyarrow.Table or None
        The kept cycles of a cycle-run session (store cycles schema).
    """

    points: pa.Table
    rejected: pa.Table
    samples_path: Path | None
    info: dict
    cycles: pa.Table | None = None


def points_table(session: Session, cols: dict, n_samples, t_start, t_end,
                 source: str) -> pa.Table:
    """Assemble the points table (store schema) of one session.

    Parameters
    ----------
    session : Session
        Gives ``session_id`` and ``mode``.
    cols : dict
        ``speed_rpm``, ``torque_nm``, ``p_mech_w``, ``p_elec_w`` and their ``*_std``
        arrays in the drum frame [rpm, N m, W]; the temperature means
        (``t_winding_c``, ...) [degC] where logged (NaN otherwise).
    n_samples : array
        Samples averaged per point.
    t_start, t_end : array
        Window bounds on the DAQ clock [s] (NaN for tables).
    source : str
        ``"timeseries"`` or ``"operating_point_table"``.
    """
    data = {k: np.asarray(v, np.float64) for k, v in cols.items()}
    m = len(n_samples)
    arrays = {
        "session_id": pa.array([session.session_id] * m, pa.string()),
        "point_id": pa.array(np.arange(m, dtype=np.int32)),
        "mode": pa.array([session.mode] * m, pa.string()),
        "quadrant": pa.array(steady.quadrant(data["p_mech_w"]).tolist(), pa.string()),
        "source": pa.array([source] * m, pa.string()),
        **{k: pa.array(data[k]) for k in (
            "speed_rpm", "torque_nm", "p_mech_w", "p_elec_w",
            "speed_rpm_std", "torque_nm_std", "p_mech_w_std", "p_elec_w_std")},
        "n_samples": pa.array(np.asarray(n_samples, np.int64)),
        "t_start_s": pa.array(np.asarray(t_start, np.float64)),
        "t_end_s": pa.array(np.asarray(t_end, np.float64)),
        **{k: pa.array(data.get(k, np.full(m, np.nan))) for k in TEMPERATURE_COLUMNS},
    }
    return pa.table(arrays, schema=POINTS_SCHEMA)


def rejected_table(sid: str, rows: list[tuple[float, float, str]]) -> pa.Table:
    """The rejected windows ``(t_start [s], t_end [s], reason)`` of session ``sid``."""
    return pa.table({
        "session_id": pa.array([sid] * len(rows), pa.string()),
        "t_start_s": pa.array([r[0] for r in rows], pa.float64()),
        "t_end_s": pa.array([r[1] for r in rows], pa.float64()),
        "reason": pa.array([r[2] for r in rows], pa.string()),
    }, schema=REJECTED_SCHEMA)
