"""The output folder of ``bench cycle verify`` (docs/schemas.md §11): its files, its one
writer and its readers (the report's).

``verify.json`` (the record, schema :data:`SCHEMA_NAME`), ``cycles.csv`` (one row per kept
cycle) and ``one_cycle.csv`` (the power over the middle kept cycle).
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from kernel.files import read_csv, read_document, write_csv, write_json
from kernel.output_folder import output_folder
from kernel.provenance import Provenance

SCHEMA_NAME = "drivebench.cycle_verify"
SCHEMA_VERSION = 1
STAGE = "cycle-verify"
RECORD_FILE = "verify.json"
CYCLES_FILE = "cycles.csv"
ONE_CYCLE_FILE = "one_cycle.csv"
#: files by which an earlier output of the stage is known
MARKERS = (RECORD_FILE,)
#: the columns the readers rely on
CYCLE_COLUMNS = ("cycle_id", "e_elec_j", "u_elec_j", "e_elec_model_j", "e_elec_optimizer_j",
                 "e_mech_j", "u_mech_j")
ONE_CYCLE_COLUMNS = ("time_s", "p_elec_measured_w", "p_elec_model_w", "p_elec_optimizer_w",
                     "p_mech_measured_w")
_EXPECTED = "the output of bench cycle verify (docs/schemas.md section 11)"


def write_verify_folder(out: str | Path, provenance: Provenance, record: dict,
                        cycles: pd.DataFrame, one_cycle: pd.DataFrame) -> Path:
    """Write the folder whole (:func:`kernel.output_folder.output_folder`)."""
    with output_folder(out, STAGE, MARKERS, provenance=provenance) as stage:
        write_json(stage / RECORD_FILE, {"schema": SCHEMA_NAME, "schema_version": SCHEMA_VERSION,
                                         "provenance": provenance.header(), **record},
                   non_finite="null")
        write_csv(stage / CYCLES_FILE, cycles)
        write_csv(stage / ONE_CYCLE_FILE, one_cycle)
    return Path(out)


def read_record(folder: Path) -> dict:
    """``verify.json``, its schema checked."""
    return read_document(Path(folder) / RECORD_FILE, SCHEMA_NAME, expected=_EXPECTED)


def _numbers(path: Path, columns: tuple[str, ...]) -> pd.DataFrame:
    frame = read_csv(path, columns, expected=_EXPECTED)
    return frame[list(columns)].apply(pd.to_numeric, errors="coerce")


def read_cycles(folder: Path) -> pd.DataFrame:
    """``cycles.csv``: the columns of :data:`CYCLE_COLUMNS` as numbers (NaN when empty)."""
    return _numbers(Path(folder) / CYCLES_FILE, CYCLE_COLUMNS)


def read_one_cycle(folder: Path) -> pd.DataFrame:
    """``one_cycle.csv``: the columns of :data:`ONE_CYCLE_COLUMNS` as numbers."""
    return _numbers(Path(folder) / ONE_CYCLE_FILE, ONE_CYCLE_COLUMNS)
