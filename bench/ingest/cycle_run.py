"""One cycle-run session: a drive profile flown on the bench, cut into its cycles.

Read, mapped into the drum frame, tared and aligned as a timeseries session
(:mod:`bench.ingest.timeseries`, the same passes), but instead of steady windows the
run is cut into the cycles of the profile ``[cycle] profile`` names
(:mod:`bench.ingest.cycles`). Each kept cycle's measured electrical energy (the
analyzer's records on the DAQ clock), mechanical energy (the DAQ's speed and torque) and
tracking go to the store's ``cycles`` table; each rejected cycle to ``rejected`` with its
reason. A cycle run gives no operating points.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from bench.cycle_profile import (
    E_MECH_RTOL,
    PROVENANCE_KEYS,
    DriveProfile,
    read_profile,
    window_integral,
)
from bench.ingest import checks, steady
from bench.ingest.analyzer import read_checked_analyzer
from bench.ingest.checks import check_torque_sign
from bench.ingest.csv_stream import CHUNK_BYTES
from bench.ingest.cycles import CycleCut, cut_cycles
from bench.ingest.mapping import Mapping
from bench.ingest.samples_file import write_samples
from bench.ingest.scan import bin_stream, scan_stream
from bench.ingest.session import Session
from bench.ingest.store_tables import SessionOutput, rejected_table
from bench.ingest.timeseries import open_stream, session_electrical_power, session_info
from bench.store.schema import CYCLES_SCHEMA
from kernel.errors import InputError
from kernel.files import file_sha256
from kernel.units import RPM_PER_RAD_S

#: a kept cycle whose samples hold a non-finite value, or whose energies are not finite
INVALID = "cycle with invalid samples"
#: the measurements of a cycle that must be finite for it to be kept
_FINITE = ("e_elec_j", "e_mech_j", "angle_rad", "p_elec_start_w", "p_elec_end_w")


def _cycle_rows(cut: CycleCut, samples: dict, power) -> dict[str, list]:
    """The kept cycles' measurements (store ``cycles`` columns but the session id); a
    kept cycle whose samples or energies are not finite is moved to the rejected ones
    (:data:`INVALID`, with a note saying which samples)."""
    t = samples["time_s"]
    rows: dict[str, list] = {f.name: [] for f in CYCLES_SCHEMA if f.name != "session_id"}
    if power is not None and power.t_s is not None:
        t_p, p = power.t_s, power.p_w
    else:
        t_p, p = t, samples["p_elec_w"]
    omega = np.abs(samples["speed_rpm"]) / RPM_PER_RAD_S
    for k in list(cut.kept):
        a, b = cut.bounds(k)
        inside = (t >= a) & (t < b)
        rms_n, rms_t, offset = cut.tracking[k]
        temp = samples["t_winding_c"][inside]
        values = {"cycle_id": k, "t_start_s": a, "t_end_s": b, "period_s": cut.period_s,
                  "e_elec_j": window_integral(t_p, p, a, b),
                  "e_mech_j": window_integral(t, samples["p_mech_w"], a, b),
                  "angle_rad": window_integral(t, omega, a, b),
                  "p_elec_start_w": float(np.interp(a, t_p, p)),
                  "p_elec_end_w": float(np.interp(b, t_p, p)),
                  "n_samples": int(inside.sum()), "n_records": int(((t_p >= a) & (t_p < b)).sum()),
                  "speed_rms_error_rpm": rms_n, "torque_rms_error_nm": rms_t,
                  "start_offset_s": offset,
                  "t_winding_c": float(np.nanmean(temp)) if np.isfinite(temp).any() else np.nan}
        why = _invalid(values, samples, inside, (t_p >= a) & (t_p < b), p)
        if why:
            cut.kept.remove(k)
            cut.rejected[k] = INVALID
            cut.notes.append(f"cycle {k} ({a:.2f} to {b:.2f} s): {why}")
            continue
        for key, v in values.items():
            rows[key].append(v)
    return rows


def _invalid(values: dict, samples: dict, inside: np.ndarray, records: np.ndarray,
             p: np.ndarray) -> str:
    """Why a cycle's measurements cannot be kept ("" when they can): the count of
    non-finite samples of each quantity inside it, or the energy that is not finite."""
    bad = {name: int((~np.isfinite(samples[name][inside])).sum())
           for name in ("speed_rpm", "p_mech_w")}
    bad["p_elec_w"] = int((~np.isfinite(p[records])).sum())
    found = [f"{n} {name}" for name, n in bad.items() if n]
    if found:
        return ("invalid samples inside it (non-finite: " + ", ".join(found)
                + "), so its energies are not measured")
    nan = [key for key in _FINITE if not np.isfinite(values[key])]
    return f"{nan[0]} not finite" if nan else ""


def profile_e_mech_j(profile: DriveProfile, path: Path) -> float:
    """The profile's own mechanical energy per cycle, its set-points integrated (mean
    over the cycles) [J], checked against the header's ``e_mech_pred_j``.

    Raises
    ------
    InputError
        The set-points integrate to another energy than the header states (a header
        relabelled after the export, or a body edited): naming the key.
    """
    body = float(np.mean(profile.e_mech_cycles_j()))
    head = float(profile.header["e_mech_pred_j"])
    if not abs(body - head) <= E_MECH_RTOL * abs(head):
        raise InputError(path, f"the set-points integrate to {body:.1f} J of mechanical "
                         f"energy per cycle, the header's e_mech_pred_j (scenario "
                         f"{profile.header['scenario']!r}) is {head:.1f} J: the header does "
                         "not describe this cycle", column="e_mech_pred_j",
                         expected=f"the profile as bench cycle export wrote it (within "
                         f"{100 * E_MECH_RTOL:g} %)")
    return body


def _rounded(x: float, digits: int) -> float | None:
    """``x`` rounded, None when not finite (the manifest is strict JSON)."""
    return round(x, digits) if np.isfinite(x) else None


def cycles_table(sid: str, rows: dict[str, list]) -> pa.Table:
    """The kept cycles as a table of the store's cycles schema."""
    n = len(rows["cycle_id"])
    return pa.table({"session_id": pa.array([sid] * n, pa.string()),
                     **{f.name: pa.array(rows[f.name], f.type) for f in CYCLES_SCHEMA
                        if f.name != "session_id"}}, schema=CYCLES_SCHEMA)


def _read_samples(path: Path) -> dict[str, np.ndarray]:
    cols = ("time_s", "speed_rpm", "p_mech_w", "p_elec_w", "t_winding_c")
    table = pq.read_table(path, columns=list(cols))
    return {c: table.column(c).to_numpy() for c in cols}


def _cycles_entry(profile: DriveProfile, path: Path, cut: CycleCut, e_mech_body: float) -> dict:
    """The session's ``cycles`` entry of the store manifest (docs/schemas.md section 2)."""
    return {
        "profile": path.name, "scenario": profile.header["scenario"],
        "n_profile_cycles": profile.n_cycles, "n_kept": len(cut.kept),
        "period_profile_s": profile.period_s, "period_s": round(cut.period_s, 6),
        "period_found_s": _rounded(cut.period_found_s, 6),
        "period_found_u_s": _rounded(cut.period_found_u_s, 7),
        "phase_s": round(cut.phase_s, 6), "correlation": round(cut.correlation, 5),
        "speed_gain": round(cut.gains["speed"], 5), "torque_gain": round(cut.gains["torque"], 5),
        "e_elec_pred_j": profile.header["e_elec_pred_j"],
        "e_mech_pred_j": profile.header["e_mech_pred_j"],
        "e_mech_profile_j": round(e_mech_body, 3), "profile_sha256": file_sha256(path),
        "provenance": {k: str(profile.header.get(k, "")) for k in PROVENANCE_KEYS},
        "notes": cut.notes}


def process_cycle_run(session: Session, mapping: Mapping, scratch: Path,
                      config: steady.SteadyConfig = steady.DEFAULT_STEADY,
                      chunk_bytes: int = CHUNK_BYTES,
                      progress: Callable[[int], None] = lambda n: None) -> SessionOutput:
    """Read, align and cut one cycle-run session; stage its samples file.

    Parameters are those of :func:`bench.ingest.timeseries.process_timeseries`.

    Raises
    ------
    InputError
        Besides a timeseries session's: the profile is missing or bad, the run does not
        follow it, or the log's frame does not match it (:func:`cut_cycles`).
    """
    sid = session.session_id
    profile_path = session.profile()
    profile = read_profile(profile_path)
    e_mech_body = profile_e_mech_j(profile, profile_path)
    daq = open_stream(session, mapping, chunk_bytes)
    sources = checks.sources_from_meta(daq.path, daq.metadata["columns"])
    record = None if session.single_stream else read_checked_analyzer(session, mapping, sources)
    extra = tuple(q for q in ("p_elec", "p_mech") if q in daq.metadata["columns"])
    scan = scan_stream(session, daq, extra, scratch, config, progress)
    binned = bin_stream(scan, daq, config)
    config = replace(config, bin_s=binned.dt)
    power = session_electrical_power(session, daq, record, binned, scan, sources, config)
    check_torque_sign(session, binned.means["p_mech"], power.p_elec_bins, daq.path)
    cut = cut_cycles({"t": binned.centres(), "speed": binned.means["speed"],
                      "torque": binned.means["torque"], "p_elec": power.p_elec_bins,
                      "recorded": power.recorded,
                      "gap": binned.gap()}, profile,
                     {"session": session.path, "profile": profile_path, "daq": daq.path,
                      **({} if session.single_stream else {"analyzer": session.file("analyzer")})})
    samples_path = scratch / f"{sid}.samples.parquet"
    empty = np.empty(0)
    stats = write_samples(samples_path, session, scan, binned.offset_nm,
                          None if record is None else power, empty, empty, progress,
                          daq.size_bytes)
    rows = _cycle_rows(cut, _read_samples(samples_path), None if record is None else power)
    cut.notes.sort(key=lambda line: int(line.split()[1]))
    rejected = rejected_table(sid, [(*cut.bounds(k), r) for k, r in sorted(cut.rejected.items())])
    info = session_info(daq, record, power.clock, binned, scan,
                         steady.Windows([], [], {}), np.ones(binned.n_bins, bool), config)
    info["no_points_note"] = (f"a cycle run: {len(cut.kept)} of {profile.n_cycles} cycles "
                              "kept, no operating points")
    info["cycles"] = _cycles_entry(profile, profile_path, cut, e_mech_body)
    return SessionOutput(points=stats.points_table(session, empty, empty), rejected=rejected,
                         samples_path=samples_path, info=info,
                         cycles=cycles_table(sid, rows))
