"""The power model an optimize folder flew with, for predictions at other speeds and torques."""

from __future__ import annotations

from pathlib import Path

from fitting.model_file import load_power_model
from fitting.power_model import PowerModel
from kernel.errors import InputError


def sweep_power_model(folder: Path, manifest: dict) -> PowerModel:
    """The sweep's power model: the file its manifest's ``drive_model`` names (the folder's
    own ``power_model.json`` when that is the one), checked against the recorded hash.

    Raises
    ------
    InputError
        The file is gone or is not the one the sweep flew with.
    """
    record = manifest.get("drive_model") or {}
    path = Path(record.get("path") or folder / "power_model.json")
    if not path.is_file() and (folder / "power_model.json").is_file():
        path = folder / "power_model.json"
    if not path.is_file():
        raise InputError(folder / "manifest.json", f"the sweep's power model {path} is gone",
                         column="drive_model.path",
                         expected=f"the power_model.json the sweep flew with back at {path}, "
                                  f"or a copy of it as {folder / 'power_model.json'} (its hash "
                                  "is checked); or run bench optimize again")
    model = load_power_model(path)
    want = record.get("model_sha256")
    if want and model.sha256 != want:
        raise InputError(path, "is not the power model the sweep flew with "
                         f"(model_sha256 {model.sha256[:12]}..., the manifest names "
                         f"{want[:12]}...)", column="drive_model.model_sha256",
                         expected=f"the sweep's power model back at {path} (the manifest "
                                  "names its hash), or run bench optimize again with this "
                                  "model")
    return model
