"""The store's layout and file schemas: Parquet columns with units, manifest version,
folder names (docs/schemas.md section 2)."""

from __future__ import annotations

import re

import pyarrow as pa

SCHEMA_NAME = "drivebench.store"
SCHEMA_VERSION = 3  # 3: cycles/ (cycle-run sessions)
#: manifests this version reads (1: no generations, files directly in <store>/<kind>;
#: 2: no cycles/)
READABLE_VERSIONS = (1, 2, 3)
KINDS = ("points", "samples", "rejected", "cycles")
LOCK_FILE = ".lock"
STAGING_PREFIX = ".staging-"
GENERATION_RE = re.compile(r"^gen-(\d{6,})$")


def _f(name: str, typ: pa.DataType, unit: str | None = None) -> pa.Field:
    return pa.field(name, typ, metadata=None if unit is None else {"unit": unit})


#: the logged temperatures in degC, NaN where a session has none (bench.ingest.temperature)
TEMPERATURE_COLUMNS = ("t_winding_c", "t_housing_c", "t_coolant_c", "t_ambient_c")
TEMPERATURE_FIELDS = tuple(_f(name, pa.float64(), "degC") for name in TEMPERATURE_COLUMNS)

POINTS_SCHEMA = pa.schema([
    _f("session_id", pa.string()),
    _f("point_id", pa.int32()),
    _f("mode", pa.string()),
    _f("quadrant", pa.string()),
    _f("source", pa.string()),
    _f("speed_rpm", pa.float64(), "rpm"),
    _f("torque_nm", pa.float64(), "N m"),
    _f("p_mech_w", pa.float64(), "W"),
    _f("p_elec_w", pa.float64(), "W"),
    _f("speed_rpm_std", pa.float64(), "rpm"),
    _f("torque_nm_std", pa.float64(), "N m"),
    _f("p_mech_w_std", pa.float64(), "W"),
    _f("p_elec_w_std", pa.float64(), "W"),
    _f("n_samples", pa.int64()),
    _f("t_start_s", pa.float64(), "s"),
    _f("t_end_s", pa.float64(), "s"),
    *TEMPERATURE_FIELDS,
])

SAMPLES_SCHEMA = pa.schema([
    _f("session_id", pa.dictionary(pa.int32(), pa.string())),
    _f("time_s", pa.float64(), "s"),
    _f("speed_rpm", pa.float64(), "rpm"),
    _f("torque_nm", pa.float64(), "N m"),
    _f("p_mech_w", pa.float64(), "W"),
    _f("p_elec_w", pa.float64(), "W"),
    _f("point_id", pa.int32()),
    *TEMPERATURE_FIELDS,
])

REJECTED_SCHEMA = pa.schema([
    _f("session_id", pa.string()),
    _f("t_start_s", pa.float64(), "s"),
    _f("t_end_s", pa.float64(), "s"),
    _f("reason", pa.string()),
])

#: one row per kept cycle of a cycle-run session (bench.ingest.cycle_run)
CYCLES_SCHEMA = pa.schema([
    _f("session_id", pa.string()),
    _f("cycle_id", pa.int32()),
    _f("t_start_s", pa.float64(), "s"),
    _f("t_end_s", pa.float64(), "s"),
    _f("period_s", pa.float64(), "s"),
    _f("e_elec_j", pa.float64(), "J"),
    _f("e_mech_j", pa.float64(), "J"),
    _f("angle_rad", pa.float64(), "rad"),
    _f("p_elec_start_w", pa.float64(), "W"),
    _f("p_elec_end_w", pa.float64(), "W"),
    _f("n_samples", pa.int64()),
    _f("n_records", pa.int64()),
    _f("speed_rms_error_rpm", pa.float64(), "rpm"),
    _f("torque_rms_error_nm", pa.float64(), "N m"),
    _f("start_offset_s", pa.float64(), "s"),
    _f("t_winding_c", pa.float64(), "degC"),
])

#: kind -> the schema of its files
SCHEMAS = {"points": POINTS_SCHEMA, "samples": SAMPLES_SCHEMA, "rejected": REJECTED_SCHEMA,
           "cycles": CYCLES_SCHEMA}
