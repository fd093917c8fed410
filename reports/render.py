"""Build the report: read every stage's files, render the Jinja2 template, write atomically."""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path

from jinja2 import Environment, PackageLoader, StrictUndefined, select_autoescape

from fitting.fit_folder import SUMMARY_FILE, read_fit_summary
from kernel.files import write_text_durable
from reports import (
    campaign_section,
    efficiency_section,
    energy_section,
    model_section,
    optimization_section,
    provenance_section,
    verification_section,
)
from reports.inputs import InputLog
from reports.section_list import SECTIONS, section_list

__all__ = ["SECTIONS", "build_context", "build_report", "render"]

def environment() -> Environment:
    """The Jinja2 environment: templates from the package, autoescape on for everything."""
    return Environment(
        loader=PackageLoader("reports", "templates"),
        autoescape=select_autoescape(default=True, default_for_string=True),
        undefined=StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
    )


def build_context(store: Path, fit: Path, optimize: Path, argv: list[str],
                  aep: Path = Path("aep_out"), size: Path = Path("size_out"),
                  verify: Path = Path("verify_out")) -> dict:
    """Read the stage outputs and return the template context (one dict per section).

    Parameters
    ----------
    store, fit, optimize : Path
        The ``bench ingest``, ``bench fit`` and ``bench optimize`` output folders;
        any of them may be missing or partial.
    aep, size, verify : Path
        The ``bench aep``, ``bench size`` and ``bench cycle verify`` output folders
        (optional).
    argv : list of str
        The report's command line, for provenance.
    """
    started = datetime.now(UTC)
    log = InputLog()
    campaign = campaign_section.campaign_section(log, store)
    points, manifest = campaign.pop("points"), campaign.pop("manifest")
    model = model_section.read_model(log, fit)
    summary = log.read(fit, SUMMARY_FILE, read_fit_summary)
    efficiency = efficiency_section.efficiency_section(log, fit, model, summary)
    power = model_section.power_model_section(log, fit, model, points, summary)
    opt = optimization_section.optimization_section(
        log, optimize, efficiency.pop("map"), model.sha256 if model is not None else None)
    energy = energy_section.energy_section(log, aep, size)
    documents = energy.pop("documents")
    verification = verification_section.verification_section(log, verify)
    prov = provenance_section.provenance_section(log, argv, started, {
        "ingest": (store, manifest),
        # the fit's header is in fit_summary.json; a model alone names its command line
        "fit": (fit, {**(model.to_dict() if model else {}), **(summary or {})}
                if model or summary else None),
        "optimize": (optimize, opt["manifest"]), "aep": (aep, documents["aep"]),
        "size": (size, documents["size"]),
        "cycle verify": (verify, verification["record"])})
    for section, folder, stage in ((campaign, store, "ingest"), (efficiency, fit, "fit"),
                                   (power, fit, "fit"), (opt, optimize, "optimize")):
        not_run(section, folder, stage)
    prov["missing"] = [m for m in prov["missing"] if not _under_absent(m, (
        store, fit, optimize, aep, size, verify))]
    return {
        "title": "drivebench report",
        "sections": section_list(),
        "headline": (headline(campaign, power, opt) + energy_headline(energy)
                     + ([("bench round trip (cycle verify)", verification["headline"])]
                        if verification["headline"] else [])),
        "paths": stage_paths({"ingest": store, "fit": fit, "optimize": optimize, "aep": aep,
                              "size": size, "cycle verify": verify}),
        "campaign": campaign,
        "efficiency": efficiency,
        "power": power,
        "optimization": opt,
        "energy": energy,
        "verification": verification,
        "provenance": prov,
    }


def _under_absent(path: str, folders: tuple[Path, ...]) -> bool:
    """Whether ``path`` lies in one of ``folders`` that does not exist (a stage not run)."""
    return any(not Path(f).is_dir() and Path(path).is_relative_to(f) for f in folders)


def not_run(section: dict, folder: Path, stage: str) -> None:
    """A section whose stage's output ``folder`` does not exist says the stage was not run
    (``not_run``) instead of listing each of its files as missing: a report of the stages
    a user ran shows what applies (a folder that exists without its files is a missing
    input, and stays one)."""
    if Path(folder).is_dir():
        section.setdefault("not_run", [])
        return
    section["missing"] = [m for m in section["missing"] if not _under_absent(m, (folder,))]
    section["not_run"] = [f"bench {stage} (no {folder})"]


def stage_paths(folders: dict[str, Path]) -> dict:
    """The stage output folders for the report's header: ``found`` and ``absent``, each a
    list of ``{"stage", "folder"}``."""
    rows = [{"stage": stage, "folder": str(folder)} for stage, folder in folders.items()]
    return {"found": [r for r in rows if Path(r["folder"]).is_dir()],
            "absent": [r for r in rows if not Path(r["folder"]).is_dir()]}


def headline(campaign: dict, power: dict, opt: dict) -> list[tuple[str, str]]:
    """Key results for the top of the report, taken from the section contexts."""
    rows = []
    totals = campaign["totals"]
    if totals["points"] is not None:
        rows.append(("operating points", f"{totals['points']} ({totals['motor']} motor, "
                                         f"{totals['generator']} generator quadrant)"))
    stats = {r["name"]: r for r in power["statistics"]}
    if stats:
        rows.append(("power model residual", f"std {stats['std of residual']['pct']}, max "
                     f"{stats['max |residual|']['pct']} of nominal (paper: 1.6 %, < 5 %)"))
    if opt["table_ii"] is not None:
        rows.append(("optimizations", f"{opt['n_scenarios'] - opt['n_failed']} of "
                                      f"{opt['n_scenarios']} converged"))
    for c in opt["cut_in"]:
        if c["cut_in"]:  # found by the sweep's search; the table says why not otherwise
            rows.append((f"cut-in, {c['label'] or c['kind']}", f"{c['cut_in']} m/s"))
    verdicts = [c["verdict"] for c in opt["claims"] or [] if c["verdict"] != "does not apply"]
    if verdicts:  # another kite: the paper's statements are about the paper's
        rows.append(("paper's statements", ", ".join(
            f"{verdicts.count(v)} {v}" for v in dict.fromkeys(verdicts))))
    rows += opt["key_warnings"]
    return rows


def energy_headline(energy: dict) -> list[tuple[str, str]]:
    """Key energy results: the AEP of the constrained electrical optimum with the share of
    the site it covers, and the drive sizing's decision (:func:`reports.energy_section.
    decision_rows`)."""
    rows = []
    for r in energy["table"]:
        if r["kind"].startswith("elec-lim"):
            band = (f"95 %: {r['band']}" if r["band"] != "n/a" else
                    "no 95 % band: the notes of section 5 say why")
            rows.append(("electrical AEP (elec-lim)",
                         f"{r['aep_elec']} MWh/yr ({band}), "
                         f"capacity factor {r['cf_elec']}; {r['coverage']}"))
    if energy["sizing"] is not None:
        rows += energy["sizing"]["headline"]
    return rows


def render(context: dict) -> str:
    """The HTML text of the report for a context from :func:`build_context`."""
    return environment().get_template("report.html").render(**context)


def build_report(store: Path, fit: Path, optimize: Path, out: Path, argv: list[str],
                 aep: Path = Path("aep_out"), size: Path = Path("size_out"),
                 verify: Path = Path("verify_out")) -> Path:
    """Read the stage outputs, render the report and write it to ``out``; returns ``out``."""
    return write_text_durable(out, render(build_context(store, fit, optimize, argv, aep, size,
                                                        verify)))
