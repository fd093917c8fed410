"""One operating-point-table session: pre-averaged points (one row each) into store points."""

from __future__ import annotations

import math

import numpy as np

from bench.ingest import checks, steady
from bench.ingest.csv_layout import line_of_row
from bench.ingest.drum_frame import check_drum_torque, fold_signed
from bench.ingest.mapping import Mapping
from bench.ingest.readers import read_points_table
from bench.ingest.session import Session
from bench.ingest.store_tables import SessionOutput, points_table, rejected_table
from kernel.errors import InputError
from kernel.units import RPM_PER_RAD_S

#: the largest count stored exactly (float64 integers are exact up to 2**53)
MAX_COUNT = 2**53


def _counts(frame, path, meta: dict, layout) -> np.ndarray:
    """The table's sample-count column as int64 (0 where it has none or a cell is empty).

    Raises
    ------
    InputError
        A negative, fractional or absurdly large count (naming its line).
    """
    if "n_samples" not in frame:
        return np.zeros(len(frame), np.int64)
    raw = frame["n_samples"].to_numpy(dtype=float)
    bad = np.isfinite(raw) & ((raw < 0) | (raw != np.round(raw)) | (raw > MAX_COUNT))
    bad |= np.isinf(raw)
    if bad.any():
        k = int(np.argmax(bad))
        column = meta.get("columns", {}).get("n_samples", {}).get("column", "n_samples")
        raise InputError(path, f"bad sample count {raw[k]!r}", line=line_of_row(layout, k),
                         column=str(column), expected=f"a whole number from 0 to {MAX_COUNT}")
    return np.nan_to_num(raw).astype(np.int64)


def process_table(session: Session, mapping: Mapping) -> SessionOutput:
    """Read an operating-point table session into store points (drum frame, SI)."""
    path = session.file("points")
    frame, meta = read_points_table(path, mapping)
    layout = meta.pop("layout")
    sources = checks.sources_from_meta(path, meta["columns"])
    checks.check_signal(sources["p_elec"], "p_elec", frame["p_elec_w"].to_numpy(), True)
    for q, name in (("speed", "speed_rpm"), ("torque", "torque_nm")):
        checks.check_signal(sources[q], q, frame[name].to_numpy(), False)
    gear = session.gear_ratio if session.measured_side == "motor" else 1.0
    speed = frame["speed_rpm"].to_numpy() * session.speed_sign / gear
    torque = frame["torque_nm"].to_numpy() * session.torque_sign * gear
    if session.signed_torque:  # torque < 0 logged in generator mode: flip speed and torque
        speed, torque = fold_signed(speed, torque)
    p_elec = frame["p_elec_w"].to_numpy()
    omega_t = speed * torque / RPM_PER_RAD_S
    values = {"speed": speed, "torque": torque, "p_elec": p_elec}
    if "p_mech_w" in frame:  # only ever a mapped column (bench.ingest.mapping)
        p_mech = frame["p_mech_w"].to_numpy() * session.speed_sign * session.torque_sign
        values["p_mech"] = p_mech
    else:
        p_mech = omega_t
    nan = np.full(len(frame), np.nan)
    std = {
        "speed_rpm_std": frame.get("speed_rpm_std", nan) / gear,
        "torque_nm_std": frame.get("torque_nm_std", nan) * gear,
        "p_mech_w_std": frame.get("p_mech_w_std", nan),
        "p_elec_w_std": frame.get("p_elec_w_std", nan),
    }
    checks.check_torque_sign(session, omega_t, p_elec, path)
    implausible = checks.check_points(values, sources, checks.explicit_ranges(session), path)
    ok = np.isfinite(speed) & np.isfinite(torque) & np.isfinite(p_elec) & np.isfinite(p_mech)
    reasons = ["invalid samples" if not good else why
               for good, why in zip(ok, implausible, strict=True)]
    ok &= np.array([why is None for why in implausible], bool)
    cols = {"speed_rpm": speed, "torque_nm": torque, "p_mech_w": p_mech, "p_elec_w": p_elec}
    cols.update({k: np.asarray(v, np.float64) for k, v in std.items()})
    cols = {k: v[ok] for k, v in cols.items()}
    if not session.signed_torque:
        tol = steady.DEFAULT_STEADY.floor_frac * session.ranges["torque"] * gear
        check_drum_torque(session, cols["torque_nm"], tol, path)
    n_samples = _counts(frame, path, meta, layout)[ok]
    nan_ok = np.full(int(ok.sum()), np.nan)
    points = points_table(session, cols, n_samples, nan_ok, nan_ok, "operating_point_table")
    rejected = rejected_table(session.session_id, [(math.nan, math.nan, why)
                                                   for why in reasons if why is not None])
    info = {"clock_offset_s": None, "clock_drift_ppm": None,
            "torque_zero_offset_nm": None, "torque_zero_tare": None,
            "torque_zero_note": "operating-point table: already averaged, no standstill "
                                "samples to tare (torque taken as logged)",
            "instruments": {"points": meta}, "n_rows": len(frame)}
    return SessionOutput(points=points, rejected=rejected, samples_path=None, info=info)
