"""Build the report: read every stage's files, render the Jinja2 template, write atomically."""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path

from jinja2 import Environment, PackageLoader, StrictUndefined, select_autoescape

from kernel.files import write_text_durable
from reports import energy_section, optimization, provenance, sections
from reports.inputs import InputLog

#: the report's numbered sections in order: (anchor, title). Each section's heading and
#: the navigation bar are made from this list (the template's ``section`` macro), so the
#: two cannot disagree; the number is the position here.
SECTIONS = (
    ("campaign", "Bench campaign"),
    ("efficiency", "Efficiency map (paper Fig. 5)"),
    ("model", "Power model (paper Table I, eq. 4, Fig. 6)"),
    ("optimization", "Optimized pumping cycles"),
    ("energy", "Annual energy and drive sizing"),
    ("provenance", "Provenance"),
)


def section_list() -> list[dict]:
    """The sections for the template: ``anchor``, ``number``, ``title`` and ``short`` (the
    title without its parenthesis, for the navigation)."""
    return [{"anchor": a, "number": n, "title": t, "short": t.split(" (")[0]}
            for n, (a, t) in enumerate(SECTIONS, 1)]


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
                  aep: Path = Path("aep_out"), size: Path = Path("size_out")) -> dict:
    """Read the stage outputs and return the template context (one dict per section).

    Parameters
    ----------
    store, fit, optimize : Path
        The ``bench ingest``, ``bench fit`` and ``bench optimize`` output folders;
        any of them may be missing or partial.
    aep, size : Path
        The ``bench aep`` and ``bench size`` output folders (optional).
    argv : list of str
        The report's command line, for provenance.
    """
    started = datetime.now(UTC)
    log = InputLog()
    campaign = sections.campaign_section(log, store)
    points, manifest = campaign.pop("points"), campaign.pop("manifest")
    model = sections.read_model(log, fit)
    summary = log.json(Path(fit) / "fit_summary.json")
    efficiency = sections.efficiency_section(log, fit, model, summary)
    power = sections.power_model_section(log, fit, model, points, summary)
    opt = optimization.optimization_section(log, optimize, efficiency["grid"],
                                            model.sha256 if model is not None else None)
    energy = energy_section.energy_section(log, aep, size)
    prov = provenance.provenance_section(
        log, argv, started,
        {"ingest": manifest, "fit": summary, "optimize": opt["manifest"],
         **energy.pop("records")},
    )
    return {
        "title": "drivebench report",
        "sections": section_list(),
        "headline": headline(campaign, power, opt) + energy_headline(energy),
        "paths": {"store": str(store), "fit": str(fit), "optimize": str(optimize)},
        "campaign": campaign,
        "efficiency": efficiency,
        "power": power,
        "optimization": opt,
        "energy": energy,
        "provenance": prov,
    }


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
        rows.append((f"cut-in, {c['label'] or c['kind']}", f"{c['cut_in']} m/s"))
    if opt["claims"]:
        verdicts = [c["verdict"] for c in opt["claims"]]
        rows.append(("paper's statements", ", ".join(
            f"{verdicts.count(v)} {v}" for v in dict.fromkeys(verdicts))))
    return rows


def energy_headline(energy: dict) -> list[tuple[str, str]]:
    """Key energy results (AEP of the constrained electrical optimum, the sizing choice)."""
    rows = []
    for r in energy["table"]:
        if r["kind"].startswith("elec-lim"):
            rows.append(("electrical AEP (elec-lim)",
                         f"{r['aep_elec']} MWh/yr (95 %: {r['band']}), "
                         f"capacity factor {r['cf_elec']}; {r['coverage']}"))
    sizing = energy["sizing"]
    if sizing is not None:
        rows.append(("drive sizing", "; ".join(x for x in (
            f"smallest within {sizing['tolerance']} of the best AEP: {sizing['chosen']}",
            sizing["edge"], sizing["hours"]) if x)))
    return rows


def render(context: dict) -> str:
    """The HTML text of the report for a context from :func:`build_context`."""
    return environment().get_template("report.html").render(**context)


def build_report(store: Path, fit: Path, optimize: Path, out: Path, argv: list[str],
                 aep: Path = Path("aep_out"), size: Path = Path("size_out")) -> Path:
    """Read the stage outputs, render the report and write it to ``out``; returns ``out``."""
    return write_text_durable(out, render(build_context(store, fit, optimize, argv, aep, size)))
