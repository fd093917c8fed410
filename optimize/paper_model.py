"""The paper's drive model (Table I and eq. 4 of Stuyts et al. 2015; docs/paper_figures.md
§1), shipped as a power-model file: the drive ``bench optimize`` uses without a fitted
model, and the reference the report compares a fit with."""

from __future__ import annotations

from pathlib import Path

from fitting.model_file import load_power_model
from fitting.power_model import PowerModel

#: the shipped file (docs/schemas.md §3), with its source in ``provenance``
PAPER_MODEL_PATH = Path(__file__).resolve().parent / "data" / "paper_drive_model.json"


def paper_model() -> PowerModel:
    """The paper's Table I model, read from :data:`PAPER_MODEL_PATH`."""
    return load_power_model(PAPER_MODEL_PATH)
