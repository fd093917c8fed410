"""The files of ``bench size`` (docs/schemas.md §8): ``sizing.csv`` and ``sizing.json``.

Written all or none into the output folder (:mod:`kernel.output_folder`); the
resumable solve store ``solves/`` is kept from run to run.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from kernel.files import read_document
from kernel.provenance import HEADER_KEY, Provenance

SCHEMA_NAME = "drivebench.sizing"
SCHEMA_VERSION = 1
SIZING_FILE, TABLE_FILE = "sizing.json", "sizing.csv"
#: files by which a size output folder written before run ids is known; the
#: resumable solve store kept from run to run
SIZE_MARKERS, SIZE_KEEP = (SIZING_FILE,), ("solves",)


def edge_note(edge: str | None, best: str | None, added: list[float]) -> str | None:
    """What the edge of the candidate set means for the answer (None: the best is inside
    and no scale was added)."""
    tried = f"scales {', '.join(f'x{s:g}' for s in added)} were added beyond the edge" \
        if added else ""
    if edge is None:
        return f"{tried}; the best drive {best} now lies inside the set" if added else None
    way = "larger" if edge == "largest" else "smaller"
    return (f"the best drive {best} is the {edge} candidate{' (' + tried + ')' if added else ''}"
            f": a {way} drive may be better still; add {way} candidates (--scales, --models, "
            "or a higher --extend)")


def write_sizing(out: Path, res: Any, **kw: Any) -> dict[str, Path]:
    """:func:`write_sizing_files` into ``out``, all or none (:mod:`kernel.output_folder`);
    ``out/solves`` (the resumable solve store) is kept."""
    from kernel.output_folder import output_folder

    with output_folder(out, "size", SIZE_MARKERS, keep=SIZE_KEEP,
                       provenance=kw["provenance"]) as stage:
        files = write_sizing_files(stage, res, **kw)
    return {k: Path(out) / Path(v).relative_to(stage) for k, v in files.items()}


def write_sizing_files(out: Path, res: Any, *, site: Any, site_note: str, drive: Any,
                       resolution: Any, system: Any, wind_speeds_m_s: tuple[float, ...],
                       adaptive: bool, tolerance: float, notes: list[str], provenance: Provenance,
                       coverage: dict | None = None, decision: dict | None = None,
                       edge: dict | None = None) -> dict[str, Path]:
    """Write ``sizing.csv`` and ``sizing.json`` (docs/schemas.md §8) of a sizing result
    (:class:`energy.sizing.SizingResult`) into ``out``, of the reference drive ``drive``
    resolved as ``resolution`` (:func:`optimize.system.drive_in_force.drive_in_force`);
    returns name -> path."""
    from energy import decision as choice
    from kernel.files import write_json, write_text_atomic

    if coverage is None:  # what the grid covers and whether the choice holds, if not given
        coverage = choice.grid_coverage(site, wind_speeds_m_s, res.records)
    if decision is None:
        decision = choice.decision(res.table, res.records, site, coverage, tolerance)
    t = res.table
    files = {"csv": write_text_atomic(out / TABLE_FILE,
                                      t.to_csv(index=False, float_format="%.6g"))}
    doc = {
        "schema": SCHEMA_NAME, "schema_version": SCHEMA_VERSION,
        HEADER_KEY: provenance.header(),
        "site": {**site.to_dict(), "note": site_note},
        "reference_model": {"path": str(resolution.model_path),
                            "note": resolution.losses_note},
        "reference_drive": resolution.record(drive),
        "system": system.record(),
        "law": "P_s(n, T) = s P_1(n, T/s): c_ij -> s^(1-j) c_ij (the similarity law at the same "
               "speed); continuous torque s T_cont, peak s T_peak, same speed limit, nominal "
               "power s P_nom; a thermal model: r_th / s, c_th s, time constant and "
               "temperatures kept (the winding limit the same)",
        "wind_speeds_m_s": list(wind_speeds_m_s), "adaptive": adaptive, "tolerance": tolerance,
        "best": res.best, "chosen": res.chosen,
        "edge": edge or {"best_at": None, "added_scales": [], "note": None},
        "coverage": coverage, "decision": decision,
        "wall_time_s": res.wall_time_s, "executor": res.executor,
        "n_solved": res.n_solved, "n_loaded": res.n_cached,
        "candidates": json.loads(t.to_json(orient="records")),
        "solves": res.records, "notes": notes,
    }
    files["json"] = write_json(out / SIZING_FILE, doc, indent=1)
    return files


def read_sizing(folder: Path) -> dict:
    """The ``sizing.json`` of a size output folder, its schema checked."""
    return read_document(Path(folder) / SIZING_FILE, SCHEMA_NAME,
                         expected="the output of `bench size` (docs/schemas.md §8)")
