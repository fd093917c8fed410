"""``bench size``: electrical AEP against drive rating over candidate drives.

A thin command line over :mod:`energy.sizing`; writes ``size_out/sizing.json``,
``size_out/sizing.csv`` and the resumable solve store ``size_out/solves/``
(docs/schemas.md §8).
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime
import json
import math
import sys
from pathlib import Path
from typing import Any

from bench.errors import InputError
from energy.cli import add_site_arguments, shear_from_args, site_from_args

#: where ``bench fit`` writes its model (docs/schemas.md §4)
FIT_MODEL_PATH = Path("fit_out") / "power_model.json"
#: files by which a size output folder written before run ids is known; the
#: resumable solve store kept from run to run
SIZE_MARKERS, SIZE_KEEP = ("sizing.json",), ("solves",)
DEFAULT_SCALES = "0.5,0.75,1,1.5,2"
DEFAULT_WINDS = "5.5,7,8.5"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``bench size``."""
    parser.add_argument("--drive-model", type=Path, default=None,
                        help="reference drive's losses (power model JSON); default the system "
                             f"file's [drive] losses, else {FIT_MODEL_PATH} if it exists, else "
                             "the shipped paper model (the one used is printed)")
    parser.add_argument("--system", type=Path, default=None,
                        help="system file (kite, tether, winch, drive, wind, bounds; "
                             "docs/system_file.md); default the shipped highwind.toml. Its "
                             "[drive] is the reference drive x1")
    parser.add_argument("--scales", default=DEFAULT_SCALES,
                        help="torque-rating scales of the reference drive, comma list (default "
                             f"{DEFAULT_SCALES}); law in docs/schemas.md §8")
    parser.add_argument("--models", type=Path, nargs="*", default=(),
                        help="further candidates: power_model.json files (rated torque and "
                             "speed limit from their drive section, else the reference ones)")
    parser.add_argument("--rated-torque-nm", type=float, default=None,
                        help="reference drive's continuous (RMS) torque rating [N m] (default: "
                             "the system's [drive] continuous_torque_nm, else its max_torque_nm)")
    parser.add_argument("--max-speed-rpm", type=float, default=None,
                        help="speed limit [rpm] (default: the system's [drive] max_speed_rpm)")
    parser.add_argument("--overload", type=float, default=None,
                        help="short-time peak torque / continuous torque (default: the "
                             "system's [drive] overload, else its max_torque_nm / continuous "
                             "torque)")
    parser.add_argument("--wind-grid", default=DEFAULT_WINDS,
                        help=f"wind speeds at the reference height [m/s] (default {DEFAULT_WINDS})")
    parser.add_argument("--adaptive", action="store_true",
                        help="refine each candidate's wind grid where its power curve bends "
                             "(docs/schemas.md §9)")
    parser.add_argument("--extend", type=int, default=1, metavar="N",
                        help="when the best drive is the largest or smallest torque-rating "
                             "scale tried, add one scale beyond it and size again, up to N "
                             "times (default 1; 0: only flag it)")
    parser.add_argument("--tolerance", type=float, default=0.02,
                        help="choose the smallest drive within this share of the best AEP")
    parser.add_argument("--intervals", type=int, default=40, help="collocation intervals")
    parser.add_argument("--degree", type=int, default=4, help="Radau collocation degree")
    parser.add_argument("--workers", type=int, default=2, help="local worker processes")
    parser.add_argument("--scheduler", default=None, metavar="ADDRESS",
                        help="run on a Dask cluster at this scheduler address")
    parser.add_argument("--out", type=Path, default=Path("size_out"), help="output folder")
    add_site_arguments(parser)


def _drive_value(path: Path, key: str) -> float | None:
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, json.JSONDecodeError, UnicodeDecodeError):
        return None
    drive = data.get("drive") if isinstance(data, dict) else None
    value = drive.get(key) if isinstance(drive, dict) else None
    return float(value) if isinstance(value, int | float) and value > 0 else None


def _scales(spec: str) -> tuple[float, ...]:
    try:
        values = tuple(float(x) for x in spec.split(",") if x.strip())
    except ValueError:
        raise InputError(None, f"--scales {spec!r}: not numbers",
                         expected="a comma list of scales > 0") from None
    if not values or any(not (math.isfinite(v) and v > 0) for v in values) or \
            len(set(values)) != len(values):
        raise InputError(None, f"--scales {spec!r}", expected="distinct scales > 0")
    return values


def reference_rating(rating: Any, rated_torque_nm: float | None = None,
                     max_speed_rpm: float | None = None,
                     overload: float | None = None) -> tuple[Any, list[str]]:
    """The reference drive's rating: the system's drive in force with the given
    overrides (``--rated-torque-nm``, ``--max-speed-rpm``, ``--overload``); a continuous
    torque or an overload the system does not state is said."""
    notes = []
    for name, v in (("--rated-torque-nm", rated_torque_nm),
                    ("--max-speed-rpm", max_speed_rpm), ("--overload", overload)):
        if v is not None and not (math.isfinite(v) and v > 0):
            raise InputError(None, f"{name} {v}", expected="a value > 0")
    if overload is not None and overload < 1:
        raise InputError(None, f"--overload {overload}", expected="a factor >= 1")
    continuous = rated_torque_nm or rating.continuous_torque_nm
    if continuous is None:
        continuous = rating.max_torque_nm
        notes.append(f"the system's [drive] states no continuous_torque_nm: its torque limit "
                     f"{continuous:g} N m is taken as the continuous rating")
    overload = overload or rating.overload
    peak = overload * continuous if overload is not None else max(rating.max_torque_nm,
                                                                   continuous)
    if overload is None:
        notes.append(f"the system's [drive] states no overload: peak torque {peak:g} N m")
    return dataclasses.replace(rating, continuous_torque_nm=continuous, max_torque_nm=peak,
                               max_speed_rpm=max_speed_rpm or rating.max_speed_rpm,
                               overload=peak / continuous), notes


def build_candidates(drive: Any, scales: tuple[float, ...], models: tuple = (),
                     rated_torque_nm: float | None = None, max_speed_rpm: float | None = None,
                     overload: float | None = None) -> tuple[list, list[str]]:
    """The candidate drives of the reference drive in force (``drive``,
    :func:`optimize.system.drive.drive_in_force`) scaled by ``scales``, plus one per
    power-model file of ``models``; and notes on what was assumed."""
    from bench.drive import DriveRating
    from energy.sizing import Candidate, scaled_candidates
    from fitting.model_file import load_power_model

    rating, notes = reference_rating(drive.rating, rated_torque_nm, max_speed_rpm, overload)
    candidates = scaled_candidates(drive.model, rating, tuple(scales))
    for p in models:
        m = load_power_model(p)
        cont = _drive_value(p, "max_torque_nm") or rating.continuous_torque_nm
        own = DriveRating(_drive_value(p, "nominal_power_w") or m.nominal_power_w,
                          _drive_value(p, "max_speed_rpm") or rating.max_speed_rpm,
                          rating.overload * cont, source=str(p), continuous_torque_nm=cont,
                          overload=rating.overload, max_p_elec_w=rating.max_p_elec_w)
        candidates.append(Candidate(Path(p).stem, m, own))
    return candidates, notes


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


def run(args: argparse.Namespace) -> int:
    """Run or resume the sizing sweep (:func:`drivebench.api.size`), print the table."""
    from drivebench.api import size
    from optimize.sweep.plan import parse_wind_grid
    from optimize.system.system import load_system

    system = load_system(args.system)
    site, site_note, _ = site_from_args(args, shear_from_args(args, system))
    winds = parse_wind_grid(args.wind_grid)
    if args.out.exists() and not args.out.is_dir():
        raise InputError(args.out, "exists and is not a folder", expected="an output folder")
    if args.extend < 0:
        raise InputError(None, f"--extend {args.extend}", expected="an integer >= 0")
    print(f"site: {site_note}")
    print(f"system: {system.name} ({system.path})")
    done = size(site, args.drive_model, system=system, fit_default=FIT_MODEL_PATH,
                scales=_scales(args.scales), models=tuple(args.models), winds=winds,
                out=args.out, site_note=site_note, rated_torque_nm=args.rated_torque_nm,
                max_speed_rpm=args.max_speed_rpm, overload=args.overload,
                tolerance=args.tolerance, extend=args.extend, adaptive=args.adaptive,
                n_intervals=args.intervals,
                degree=args.degree, workers=args.workers, scheduler=args.scheduler,
                progress=True, command_line=["bench", "size", *sys.argv[2:]],
                before_solving=lambda d, n: _announce(d, n, len(winds), args.out))
    res = done.sizing
    print(res.table.to_string(index=False, float_format=lambda x: f"{x:.4g}"))
    print(f"best: {res.best}; smallest within {args.tolerance:.0%} of the best AEP: {res.chosen}")
    print(f"{res.n_solved} solved, {res.n_cached} loaded from the store, "
          f"{res.wall_time_s:.1f} s ({res.executor})")
    for n in done.notes:
        print(f"note: {n}")
    for r in (r for r in res.records if not r["success"]):
        print(f"FAILED: {r['candidate']} at {r['wind_speed_m_s']:g} m/s: {r['status']} "
              "(that candidate gets no AEP)")
    return 0 if res.chosen is not None else 1


def _announce(drive: Any, n_candidates: int, n_winds: int, out: Path) -> None:
    for line in drive.lines():
        print(line)
    print(f"{n_candidates} candidates x {n_winds} wind speeds (elec-lim, RMS torque <= "
          f"rated); solves stored in {out / 'solves'}")


def write_sizing(out: Path, res: Any, **kw: Any) -> dict[str, Path]:
    """:func:`write_sizing_files` into ``out``, all or none (:mod:`bench.output_folder`);
    ``out/solves`` (the resumable solve store) is kept."""
    from bench.output_folder import output_folder

    with output_folder(out, "size", SIZE_MARKERS, keep=SIZE_KEEP) as stage:
        files = write_sizing_files(stage, res, **kw)
    return {k: Path(out) / Path(v).relative_to(stage) for k, v in files.items()}


def write_sizing_files(out: Path, res: Any, *, site: Any, site_note: str, drive: Any,
                       system: Any, winds: tuple[float, ...], adaptive: bool, tolerance: float,
                       notes: list[str], command_line: list[str],
                       edge: dict | None = None) -> dict[str, Path]:
    """Write ``sizing.csv`` and ``sizing.json`` (docs/schemas.md §8) of a sizing result
    (:class:`energy.sizing.SizingResult`) into ``out``; returns name -> path."""
    from bench.files import write_json, write_text_atomic

    t = res.table
    files = {"csv": write_text_atomic(out / "sizing.csv",
                                      t.to_csv(index=False, float_format="%.6g"))}
    doc = {
        "schema": "drivebench.sizing", "schema_version": 1,
        "created_utc": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
        "command_line": list(command_line),
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
