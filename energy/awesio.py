"""Power curves in awesIO's YAML layout (``awegroup/awesIO``, ``power_curves_schema.yml``).

awesIO (IEA Wind Task 48) describes a power curve per wind-profile cluster:
``metadata`` (name, description, note, awesIO_version, schema, time_created,
model_config, wind_resource.reference_height), ``altitudes`` [m],
``reference_wind_speeds`` [m/s] and ``power_curves``: one entry per profile
with ``profile_id``, ``probability_weight``, ``wind_profile`` (``u_normalized``,
``v_normalized`` at ``altitudes``) and ``wind_speed_data`` (``wind_speed``,
``performance.power.average_cycle_power`` [W], ``performance.timing.cycle_time`` [s]).

awesIO's ``average_cycle_power`` is positive when the system generates (its
example files); ours is negative then, so the export writes ``-P``. Our kite
model has one wind profile (logarithmic shear, no veer), so each file holds one
profile with weight 1. One file per scenario kind and quantity (electrical /
mechanical), since an AEP tool reads ``average_cycle_power`` of a file.

The YAML is emitted by :func:`dump_yaml` (block style, JSON-compatible scalars),
so no YAML library is needed to write it.
"""

from __future__ import annotations

import datetime
import json
import math

import numpy as np

AWESIO_VERSION = "0.1.0"
AWESIO_SCHEMA = "power_curves_schema.yml"


def _scalar(value) -> str:
    if value is None:
        return "null"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int | np.integer):
        return str(int(value))
    if isinstance(value, float | np.floating):
        x = float(value)
        if not math.isfinite(x):
            return ".nan" if math.isnan(x) else (".inf" if x > 0 else "-.inf")
        return repr(x)
    return json.dumps(str(value), ensure_ascii=False)  # a JSON string is a YAML string


def dump_yaml(data, indent: int = 0) -> str:
    """Block-style YAML of nested dicts, lists and scalars (strings double-quoted)."""
    pad = " " * indent
    lines: list[str] = []
    if isinstance(data, dict):
        for key, value in data.items():
            if isinstance(value, dict | list) and value:
                lines.append(f"{pad}{key}:")
                lines.append(dump_yaml(value, indent + 2))
            elif isinstance(value, dict):
                lines.append(f"{pad}{key}: {{}}")
            elif isinstance(value, list):
                lines.append(f"{pad}{key}: []")
            else:
                lines.append(f"{pad}{key}: {_scalar(value)}")
    elif isinstance(data, list):
        for item in data:
            if isinstance(item, dict | list) and item:
                body = dump_yaml(item, indent + 2).lstrip()
                lines.append(f"{pad}- {body}")
            else:
                lines.append(f"{pad}- {_scalar(item)}")
    else:
        lines.append(pad + _scalar(data))
    return "\n".join(lines)


def power_curve_document(
    name: str,
    description: str,
    note: str,
    wind_speed_m_s: np.ndarray,
    delivered_w: np.ndarray,
    cycle_time_s: np.ndarray,
    reference_height_m: float,
    altitudes_m: np.ndarray,
    u_normalized: np.ndarray,
    model_config: dict,
) -> dict:
    """An awesIO power-curve document for one curve.

    Parameters
    ----------
    wind_speed_m_s : ndarray
        Reference wind speeds [m/s] at ``reference_height_m``.
    delivered_w : ndarray
        Average cycle power delivered [W] (positive = generated, awesIO's sign).
    cycle_time_s : ndarray
        Cycle period [s] per wind speed.
    altitudes_m, u_normalized : ndarray
        The wind profile: speed over reference speed at each altitude [m].
    model_config : dict
        Free-form description of the system (awesIO ``metadata.model_config``).
    """
    return {
        "metadata": {
            "name": name,
            "description": description,
            "note": note,
            "awesIO_version": AWESIO_VERSION,
            "schema": AWESIO_SCHEMA,
            "time_created": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
            "model_config": model_config,
            "wind_resource": {"n_clusters": 1, "reference_height": float(reference_height_m)},
        },
        "altitudes": [float(a) for a in altitudes_m],
        "reference_wind_speeds": [float(v) for v in wind_speed_m_s],
        "power_curves": [{
            "profile_id": 1,
            "probability_weight": 1.0,
            "wind_profile": {
                "u_normalized": [float(u) for u in u_normalized],
                "v_normalized": [0.0 for _ in u_normalized],
            },
            "wind_speed_data": [
                {"wind_speed": float(v),
                 "performance": {"power": {"average_cycle_power": float(p)},
                                 "timing": {"cycle_time": float(t)}}}
                for v, p, t in zip(wind_speed_m_s, delivered_w, cycle_time_s, strict=True)
            ],
        }],
    }
