"""The system a test's OCP flies: the shipped ``highwind.toml`` (the paper's kite, whose
bounds were the OCP's defaults before system files) with a power model's own rating in
force, as the OCP flew a model without a system file."""

from __future__ import annotations

import dataclasses
from typing import Any

from kernel.drive import Drive
from optimize.paper_model import paper_model
from optimize.system.system_file import load_system


def system_for(model: Any = None, **sections: dict[str, Any]) -> Any:
    """The shipped paper system with ``model``'s rating in force (speed, torque, nominal
    power; no continuous rating, no grid limit), keys of its sections changed by
    ``sections`` (``bounds={"max_line_angle_deg": 20.0}``, ``drive={...}``)."""
    model = paper_model() if model is None else model
    rating = model.drive.to_dict() if model.drive is not None else {}
    system = load_system().in_force(Drive.rating(
        nominal_power_w=rating.get("nominal_power_w", model.nominal_power_w),
        max_speed_rpm=rating["max_speed_rpm"], max_torque_nm=rating["max_torque_nm"]))
    return dataclasses.replace(system, **{
        name: dataclasses.replace(getattr(system, name), **values)
        for name, values in sections.items()})
