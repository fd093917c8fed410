"""The power-model file ``power_model.json`` (docs/schemas.md §3): read and write."""

from __future__ import annotations

import json
from pathlib import Path

from bench.errors import InputError
from bench.files import bad_number_at, read_text, write_json
from bench.output_folder import check_output_file
from fitting.model_schema import power_model_from_dict
from fitting.power_model import PowerModel


def load_power_model(path: str | Path) -> PowerModel:
    """Read and validate a power-model file (docs/schemas.md §3).

    Parameters
    ----------
    path : str or Path
        The JSON file.

    Returns
    -------
    PowerModel

    Raises
    ------
    InputError
        If the file is missing, is not JSON, or fails validation, or its folder is
        a stage output that is not whole (:func:`bench.output_folder.check_output_file`);
        the message names the file and the field.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(path, "file not found", expected="a power model JSON file")
    if path.is_file():
        check_output_file(path)
    text = read_text(path, what="power model file")
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(path, f"not valid JSON: {exc.msg}", line=exc.lineno) from exc
    except ValueError as exc:  # e.g. an integer of more digits than Python converts
        raise InputError(path, f"not valid JSON: {exc}") from exc
    bad = bad_number_at(data)
    if bad is not None:
        raise InputError(path, bad[1], column=bad[0], expected="finite numbers only")
    return power_model_from_dict(data, path)


def save_power_model(model: PowerModel, path: str | Path) -> Path:
    """Write ``model`` to ``path`` atomically (temp file in the same dir, then os.replace).

    Parameters
    ----------
    model : PowerModel
    path : str or Path
        Destination JSON file; its directory must exist.

    Returns
    -------
    Path
        The written path.
    """
    return write_json(path, model.to_dict(), non_finite="error")
