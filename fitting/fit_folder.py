"""The output folder of ``bench fit`` (docs/schemas.md §4): its files, their one writer
and their readers, used by the fit stage, the report, the Python API and the tests.

* ``power_model.json``: the fitted power model (:mod:`fitting.model_file`);
* ``efficiency_map.parquet``: the gridded efficiency map, its masking in the file metadata;
* ``selection.parquet``: the model-selection table;
* ``loss_table.csv``: the model's losses on a speed-torque grid;
* ``figures/``: the efficiency map, the power map and the residuals (SVG);
* ``fit_summary.json``: the fit's record (provenance header, statistics, notes, files).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from fitting.loss_table import write_loss_table
from fitting.model_file import load_power_model, save_power_model
from fitting.power_model import PowerModel
from kernel.files import read_document, read_parquet, write_json, write_parquet

SUMMARY_SCHEMA = "drivebench.fit_summary"
SUMMARY_VERSION = 1
SUMMARY_FILE, MODEL_FILE = "fit_summary.json", "power_model.json"
MAP_FILE, SELECTION_FILE, LOSS_TABLE_FILE = ("efficiency_map.parquet", "selection.parquet",
                                             "loss_table.csv")
#: files by which a fit output folder written before run ids is known
FIT_MARKERS = (SUMMARY_FILE, MODEL_FILE)
#: the columns of ``efficiency_map.parquet`` its readers rely on
MAP_COLUMNS = ("speed_rpm", "torque_nm", "eta")
_EXPECTED = "the output of `bench fit` (docs/schemas.md §4)"


@dataclass(frozen=True)
class FitContents:
    """What a fit writes, computed before its folder is opened.

    Parameters
    ----------
    model : PowerModel
        The chosen power model.
    efficiency_map : DataFrame
        The gridded map (:func:`fitting.efficiency_map.gridded_map`).
    map_metadata : dict
        File metadata of the map (masking rules, model and points hashes).
    selection : DataFrame
        The model-selection table.
    selection_metadata : dict
        File metadata of the table (rule, weighting, folds, reason).
    summary : dict
        ``fit_summary.json`` without its ``outputs`` list (added by the writer).
    """

    model: PowerModel
    efficiency_map: pd.DataFrame
    map_metadata: dict
    selection: pd.DataFrame
    selection_metadata: dict
    summary: dict


def write_fit_files(stage: Path, contents: FitContents,
                    draw: Callable[[Path], list[Path]]) -> dict:
    """Write every file of the fit folder into ``stage``; ``draw`` writes the figures
    into the folder it is given and returns their paths. Returns ``fit_summary.json``'s
    content."""
    stage = Path(stage)
    (stage / "figures").mkdir()
    written = [save_power_model(contents.model, stage / MODEL_FILE),
               write_parquet(stage / MAP_FILE, contents.efficiency_map,
                             metadata=contents.map_metadata),
               write_parquet(stage / SELECTION_FILE, contents.selection,
                             metadata=contents.selection_metadata),
               write_loss_table(contents.model, stage / LOSS_TABLE_FILE)]
    written += draw(stage / "figures")
    summary = {"schema": SUMMARY_SCHEMA, "schema_version": SUMMARY_VERSION,
               **contents.summary,
               "outputs": sorted(str(p.relative_to(stage)) for p in written) + [SUMMARY_FILE]}
    write_json(stage / SUMMARY_FILE, summary)
    return summary


def read_fit_summary(folder: Path) -> dict:
    """``fit_summary.json`` of a fit folder, its schema checked."""
    return read_document(Path(folder) / SUMMARY_FILE, SUMMARY_SCHEMA, expected=_EXPECTED)


def read_power_model(folder: Path) -> PowerModel:
    """``power_model.json`` of a fit folder, validated
    (:func:`fitting.model_file.load_power_model`)."""
    return load_power_model(Path(folder) / MODEL_FILE)


def read_efficiency_map(folder: Path) -> pd.DataFrame:
    """``efficiency_map.parquet`` of a fit folder, the columns of :data:`MAP_COLUMNS` checked."""
    return read_parquet(Path(folder) / MAP_FILE, MAP_COLUMNS, expected=_EXPECTED)


def read_selection(folder: Path) -> pd.DataFrame:
    """``selection.parquet`` of a fit folder (the model-selection table)."""
    return read_parquet(Path(folder) / SELECTION_FILE, expected=_EXPECTED)
