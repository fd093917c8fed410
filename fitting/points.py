"""Read and check the operating points of a store (docs/schemas.md §2) for fitting."""

from __future__ import annotations

import hashlib
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from bench.store.read import consistent_read, read_listed_bytes
from kernel.errors import InputError

#: Columns the fit needs from ``points/*.parquet``.
REQUIRED_COLUMNS = ("session_id", "point_id", "speed_rpm", "torque_nm", "p_mech_w", "p_elec_w")
NUMERIC_COLUMNS = ("speed_rpm", "torque_nm", "p_mech_w", "p_elec_w")
QUADRANTS = ("motor", "generator")


@dataclass(frozen=True)
class OperatingPoints:
    """The operating points used by a fit and where they came from.

    Parameters
    ----------
    frame : pandas.DataFrame
        One row per point with ``REQUIRED_COLUMNS`` and ``quadrant``
        (recomputed from the sign of ``p_mech_w``, docs/schemas.md §2).
    files : dict
        ``<session_id>.parquet -> sha256`` of every points file read.
    sha256 : str
        Hash over the sorted ``(file name, file sha256)`` pairs: the identity of the input.
    """

    frame: pd.DataFrame
    files: dict
    sha256: str

    def counts(self) -> dict[str, int]:
        """Number of points per quadrant."""
        vc = self.frame["quadrant"].value_counts()
        return {q: int(vc.get(q, 0)) for q in QUADRANTS}


def quadrant_of(p_mech_w: np.ndarray) -> np.ndarray:
    """``"motor"`` where the drive delivers shaft power (p_mech_w > 0), else ``"generator"``."""
    return np.where(np.asarray(p_mech_w) > 0, "motor", "generator")


def load_points(store: str | Path) -> OperatingPoints:
    """Read the points files the store's manifest lists and check them.

    Parameters
    ----------
    store : str or Path
        The store directory written by ``bench ingest``.

    Raises
    ------
    InputError
        Missing or empty store, a listed file missing or not as the manifest records
        it (naming the files and the command that repairs the store), a missing
        column, or a non-finite value (naming the file, the column and the point).
    """
    store = Path(store)
    if not store.is_dir():
        raise InputError(store, "store not found", expected="a directory written by bench ingest")

    def read_bytes(manifest: dict) -> dict[str, tuple[Path, bytes]]:
        return {f"{sid}.parquet": pair
                for sid, pair in read_listed_bytes(store, "points", manifest).items()}

    # only the files the manifest lists, each as it records it (size and SHA-256)
    listed = consistent_read(store, read_bytes)
    frames, files = [], {}
    for name, (path, data) in listed.items():
        files[name] = hashlib.sha256(data).hexdigest()
        try:
            df = pd.read_parquet(io.BytesIO(data))
        except Exception as exc:  # pyarrow raises several types for a corrupt file
            raise InputError(path, f"not a readable Parquet file ({exc})") from exc
        for col in REQUIRED_COLUMNS:
            if col not in df.columns:
                raise InputError(path, "missing column", column=col,
                                 expected=", ".join(REQUIRED_COLUMNS))
        for col in NUMERIC_COLUMNS:
            values = pd.to_numeric(df[col], errors="coerce").to_numpy(dtype=float)
            bad = ~np.isfinite(values)
            if bad.any():
                k = int(np.argmax(bad))
                raise InputError(
                    path,
                    f"non-finite value {df[col].iloc[k]!r} at point_id {df['point_id'].iloc[k]} "
                    f"(row {k + 1}; {int(bad.sum())} such rows)",
                    column=col,
                    expected="finite numbers (ingest drops invalid samples)",
                )
        if len(df):
            frames.append(df)
    if not frames:
        raise InputError(store, "store holds no operating points",
                         expected="at least one session with points in its manifest.json "
                                  "(run bench ingest)")
    frame = pd.concat(frames, ignore_index=True)
    for col in NUMERIC_COLUMNS:
        frame[col] = frame[col].astype(float)
    frame["quadrant"] = quadrant_of(frame["p_mech_w"].to_numpy())
    digest = hashlib.sha256(
        "".join(f"{name}:{sha}\n" for name, sha in sorted(files.items())).encode()
    ).hexdigest()
    return OperatingPoints(frame=frame, files=files, sha256=digest)
