"""Writers for the fit outputs: JSON and Parquet with units, atomically (see bench.files)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from bench.files import atomic_write, write_text_atomic


def write_json(path: str | Path, data) -> Path:
    """Write JSON (indented, finite numbers only) atomically."""
    text = json.dumps(data, indent=2, allow_nan=False, default=_jsonable) + "\n"
    return write_text_atomic(path, text)


def _jsonable(value):
    if hasattr(value, "item"):  # numpy scalars
        return value.item()
    if hasattr(value, "tolist"):
        return value.tolist()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def unit_of(column: str) -> str:
    """Unit from the column-name suffix (``_rpm``, ``_nm``, ``_w``, ``_pct_nominal``...)."""
    suffixes = {"_rpm": "rpm", "_nm": "N m", "_w": "W", "_rad_s": "rad/s", "_s": "s",
                "_pct_nominal": "% of nominal power"}
    for suffix, unit in suffixes.items():
        if column.endswith(suffix):
            return unit
    if column in ("eta", "eta_fit", "area_share", "eta_low", "eta_high", "r2"):
        return "1"
    return ""


def write_parquet(path: str | Path, frame: pd.DataFrame, metadata: dict | None = None) -> Path:
    """Write a frame to Parquet atomically, each field carrying ``{"unit": ...}`` metadata.

    Parameters
    ----------
    path : str or Path
    frame : pandas.DataFrame
    metadata : dict, optional
        Extra file-level key/value metadata (values JSON-encoded).
    """
    table = pa.Table.from_pandas(frame, preserve_index=False)
    fields = [
        f.with_metadata({"unit": unit_of(f.name)}) if unit_of(f.name) else f
        for f in table.schema
    ]
    schema = pa.schema(fields, metadata={
        **(table.schema.metadata or {}),
        **{k.encode(): json.dumps(v, default=_jsonable).encode()
           for k, v in (metadata or {}).items()},
    })
    table = pa.Table.from_arrays(table.columns, schema=schema)
    return atomic_write(path, lambda p: pq.write_table(table, p))


def json_safe(value):
    """Copy of nested dicts/lists with numpy scalars as Python numbers and NaN/inf as None."""
    if isinstance(value, dict):
        return {str(k): json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    if hasattr(value, "item") and not hasattr(value, "__len__"):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
