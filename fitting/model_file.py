"""The power-model file ``power_model.json`` (docs/schemas.md §3): read and write."""

from __future__ import annotations

from pathlib import Path

from fitting.model_schema import power_model_from_dict
from fitting.power_model import SCHEMA_NAME, PowerModel
from kernel.errors import InputError
from kernel.files import bad_number_at, read_json, write_json
from kernel.output_folder import check_output_file


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
        a stage output that is not whole (:func:`kernel.output_folder.check_output_file`);
        the message names the file and the field.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(path, "file not found", expected="a power model JSON file")
    try:
        check_output_file(path)
    except InputError:
        _require_power_model(path)  # another stage's document: say so, not its folder's state
        raise
    data = read_json(path, what="power model file")
    bad = bad_number_at(data)
    if bad is not None:
        raise InputError(path, bad[1], column=bad[0], expected="finite numbers only")
    return power_model_from_dict(data, path)


def _require_power_model(path: Path) -> None:
    """Raise InputError when ``path`` is a JSON document of another schema (a fit folder's
    ``fit_summary.json`` named as a power model)."""
    try:
        data = read_json(path, what="power model file")
    except InputError:
        return  # not JSON at all: the caller's error stands
    schema = data.get("schema") if isinstance(data, dict) else SCHEMA_NAME
    if schema != SCHEMA_NAME:
        raise InputError(path, f"not a power model (schema {schema!r})", column="schema",
                         expected=f"a power-model file, schema {SCHEMA_NAME!r} (bench fit's "
                         "power_model.json)")


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
