"""The files of ``bench size`` (docs/schemas.md §8): ``sizing.csv`` and ``sizing.json``.

Written all or none into the output folder (:mod:`kernel.output_folder`); the
resumable solve store ``solves/`` is kept from run to run.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from kernel.provenance import HEADER_KEY, Provenance

#: files by which a size output folder written before run ids is known; the
#: resumable solve store kept from run to run
SIZE_MARKERS, SIZE_KEEP = ("sizing.json",), ("solves",)


def grid_hours(site, winds: tuple[float, ...]) -> dict:
    """The shares of the site's hours below and above the sizing wind grid (counted as zero
    power in the sizing AEP), with a one-line note."""
    below = float(site.cdf(min(winds)))
    above = float(1.0 - site.cdf(max(winds)))
    note = (f"the sizing grid {min(winds):g}-{max(winds):g} m/s covers "
            f"{100 * (1 - below - above):.1f} % of the site's hours; {100 * below:.1f} % below "
            f"and {100 * above:.1f} % above it count as zero power in the sizing AEP")
    return {"share_below_grid": below, "share_above_grid": above, "note": note}


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
                       system: Any, winds: tuple[float, ...], adaptive: bool, tolerance: float,
                       notes: list[str], provenance: Provenance,
                       edge: dict | None = None) -> dict[str, Path]:
    """Write ``sizing.csv`` and ``sizing.json`` (docs/schemas.md §8) of a sizing result
    (:class:`energy.sizing.SizingResult`) into ``out``; returns name -> path."""
    from kernel.files import write_json, write_text_atomic

    t = res.table
    files = {"csv": write_text_atomic(out / "sizing.csv",
                                      t.to_csv(index=False, float_format="%.6g"))}
    doc = {
        "schema": "drivebench.sizing", "schema_version": 1,
        HEADER_KEY: provenance.header(),
        "site": {**site.to_dict(), "note": site_note},
        "reference_model": {"path": str(drive.model_path), "note": drive.losses_note},
        "reference_drive": drive.record(),
        "system": system.record(),
        "law": "P_s(n, T) = s P_1(n, T/s): c_ij -> s^(1-j) c_ij (the similarity law at the same "
               "speed); continuous torque s T_cont, peak s T_peak, same speed limit, nominal "
               "power s P_nom",
        "wind_speeds_m_s": list(winds), "adaptive": adaptive, "tolerance": tolerance,
        "best": res.best, "chosen": res.chosen,
        "edge": edge or {"best_at": None, "added_scales": [], "note": None},
        "hours": grid_hours(site, winds),
        "wall_time_s": res.wall_time_s, "executor": res.executor,
        "n_solved": res.n_solved, "n_loaded": res.n_cached,
        "candidates": json.loads(t.to_json(orient="records")),
        "solves": res.records, "notes": notes,
    }
    files["json"] = write_json(out / "sizing.json", doc, indent=1)
    return files
