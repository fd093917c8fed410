"""A report of another kite, of the stages a user ran (issue 49: the shipped AP2 through
optimize and aep only gave Key results with an empty cut-in, "15 does not apply", the
paper's cut-ins, a Fig. 3 slot "not run", Fig. 9 captioned over a map it did not draw, and
every stage not run listed as missing at the top).

The sweep is made up (tests/test_report.py's analytic cycles) on a 6:12:3 grid, its
manifest recording the shipped ap2.toml (``paper_system`` unset) and a cut-in search that
found none; the AEP folder is bench aep's own output of it.
"""

from __future__ import annotations

import re

import pandas as pd
import pytest
from test_report import _cycle, browser  # noqa: F401

from drivebench.cli import main
from kernel.provenance import Provenance
from optimize.sweep_folder import write_sweep_folder
from optimize.system.system_file import load_system
from reports.render import build_context, render

WINDS = (6.0, 9.0, 12.0)
KINDS = ("elec-lim", "elec-free", "mech-lim", "mech-free")


def write_other_kite(opt):
    rows, trajs = [], []
    for kind in KINDS:
        for w in WINDS:
            name = f"{kind}-{w:.1f}"
            p_e = -300.0 * w
            rows.append({"scenario": name, "kind": kind,
                         "objective": "electrical" if kind.startswith("elec") else "mechanical",
                         "drive_limits": kind.endswith("lim"), "wind_speed_m_s": w,
                         "success": True, "status": "Solve_Succeeded", "iterations": 12,
                         "period_s": 6.0, "avg_p_elec_w": p_e, "avg_p_mech_w": 1.3 * p_e,
                         "peak_speed_rpm": 900.0, "peak_torque_nm": 40.0,
                         "active_bounds": "surface_limit,ground_clearance",
                         "bound_limited": False, "slack_fraction": 0.0})
            trajs.append(_cycle(name, kind, w))
    system = load_system("optimize/data/systems/ap2.toml")
    claims = pd.DataFrame({"claim_id": ["fig3-energy"], "statement": ["Fig. 3 nets 827 J"],
                           "paper": ["827 J"], "ours": ["n/a"], "verdict": ["does not apply"],
                           "note": ["system 'ap2' is not the paper's"]})
    write_sweep_folder(
        opt, Provenance.start(["bench", "optimize", "--system", str(system.path)]),
        summary=pd.DataFrame(rows), trajectories=pd.concat(trajs, ignore_index=True),
        system=system.record(), claims=claims, carried_model=None, manifest={
            "wind_speeds_m_s": list(WINDS), "system": system.record(),
            "bound_values": {"surface_limit": [20.0, 30.0, 30.0], "ground_clearance": 100.0},
            "drive_model": {"path": "", "model_sha256": "", "name": "none"},
            "cut_in": [{"kind": "elec-lim", "cut_in_m_s": None, "bracket_lo_m_s": None,
                        "bracket_hi_m_s": None, "status": "no bracket: every grid speed "
                                                          "delivers"}],
            "trust": {"mesh": [], "simulation": []}})
    return opt


@pytest.fixture(scope="module")
def other(tmp_path_factory):
    root = tmp_path_factory.mktemp("other_kite")
    opt = write_other_kite(root / "opt")
    assert main(["aep", "--optimize", str(opt), "--rayleigh-mean", "5.5",
                 "--nominal-power-w", "20000", "--out", str(root / "aep")]) == 0
    none = root / "none"
    ctx = build_context(none, none, opt, ["bench", "report"], root / "aep", none)
    html = render(ctx)
    out = root / "report.html"
    out.write_text(html, encoding="utf-8")
    return {"ctx": ctx, "html": html, "out": out}


def test_key_results_have_no_empty_value_nor_paper_count(other):
    rows = other["ctx"]["headline"]
    assert rows and all(str(v).strip() for _, v in rows)
    assert not any("does not apply" in str(v) for _, v in rows)
    assert not any(k.startswith("cut-in") for k, _ in rows)  # the search found none


def test_no_paper_figure_is_claimed_for_another_kite(other):
    html = other["html"]
    section = html[html.index('<section id="optimization">'):]
    section = section[:section.index("</section>")]
    text = re.sub(r"<svg.*?</svg>", "", section, flags=re.S)
    assert "Paper:" not in text and "827 J" not in text.replace("Fig. 3 nets 827 J", "")
    assert "(the paper's Fig. 9)" not in section
    assert "over the measured efficiency map" not in section  # no map was drawn
    # Fig. 3 at the grid's speed nearest 5.5 m/s, not a slot saying 5.5 m/s was not run
    assert "One cycle over time (Fig. 3): electrically optimized, constrained, 6 m/s" in text
    assert "was not run" not in text
    assert "<td class=\"num\">not found</td>" in text  # the cut-in table says so


def test_stages_not_run_are_not_missing_inputs(other):
    html = other["html"]
    assert 'id="missing-inputs"' not in html
    assert "Not run: bench ingest" in html and "Not run: bench fit" in html


def test_aep_of_a_grid_above_the_cut_in_names_what_it_leaves_out(other):
    # the curve delivers at 6 m/s: no cut-in is claimed, the wind energy below and above
    # the grid is stated (Rayleigh, mean 5.5 m/s: closed forms in tests/test_sizing_decision)
    from energy.site import energy_share, rayleigh

    site = rayleigh(5.5)
    row = next(r for r in other["ctx"]["energy"]["table"] if r["kind"].startswith("elec-lim"))
    assert row["cut_in"] == "below 6"
    assert row["below"] == f"{100 * energy_share(site, 0.0, 6.0):.1f} %"
    assert row["above"] == f"{100 * energy_share(site, 12.0):.1f} %"
    assert "only part of the site's AEP" in row["coverage"]


def test_browser_key_results_have_no_empty_cell(browser, other):  # noqa: F811
    page = browser.new_page(viewport={"width": 1280, "height": 900})
    page.goto(other["out"].resolve().as_uri(), wait_until="load")
    cells = page.eval_on_selector_all("#summary td", "els => els.map(e => e.innerText.trim())")
    page.close()
    assert cells and len(cells) % 2 == 0
    values = cells[1::2]
    # a value is more than its unit: "cut-in ... m/s" once showed " m/s"
    assert all(re.search(r"[0-9A-Za-z]", re.sub(r"\b(m/s|MWh/yr|W|N m|rpm)\b", "", v))
               for v in values), cells
    assert not any(v in ("None", "nan", "n/a") for v in values)


def test_every_active_bound_is_explained(other):
    # issue 49: surface_limit was an active bound on 28 of the demo's 32 optima,
    # unconstrained kinds included, and nothing said what it is
    legend = other["ctx"]["optimization"]["bound_legend"]
    assert legend[0].startswith("surface_limit: a control surface (aileron, elevator, rudder) "
                                "at its largest deflection")
    assert "in force in every kind, the unconstrained ones included" in legend[0]
    assert legend[0].endswith("(20, 30, 30 deg)")
    assert legend[1] == "ground_clearance: the kite at its lowest allowed altitude (100 m)"
    assert '<ul id="bound-legend">' in other["html"]



def test_key_results_say_when_cycles_leave_the_model_or_lose_more_than_they_make():
    # issue 49: MegAWES cycles ran 16-98 % of their time outside the drive model's domain
    # and mech-lim drew up to 1.29 MW from the grid while generating at the drum; nothing
    # in Key results said so
    from reports.optimization_section import key_warnings

    summary = pd.DataFrame({
        "scenario": ["mech-lim-6.0", "mech-lim-9.0", "elec-lim-9.0"],
        "kind": ["mech-lim", "mech-lim", "elec-lim"], "wind_speed_m_s": [6.0, 9.0, 9.0],
        "success": [True, True, True], "avg_p_elec_w": [492923.0, -356894.0, -662985.0],
        "avg_p_mech_w": [-255605.0, -1105231.0, -981911.0],
        "outside_domain_time_frac": [0.632, 0.558, 0.278],
        "outside_domain_loss_frac": [0.887, 0.844, 0.5]})
    rows = dict(key_warnings(summary))
    assert rows["outside the drive model's domain"].startswith(
        "2 of 3 converged cycles spend most of their time outside")
    assert "mech-lim at 6, 9 m/s; worst mech-lim-6.0, 63 % of its cycle" in rows[
        "outside the drive model's domain"]
    # every cycle that draws is itemized with the losses that explain its draw (truth by
    # hand: 492923 + 255605 = 748528 W of losses, 11.3 % of them inside the domain, 84.6 kW
    # < 256 kW generated: without the extrapolated losses it would not draw)
    assert rows["drawing from the grid while generating"].endswith(
        "mech-lim at 6 m/s; largest mech-lim-6.0: 493 kW drawn, 256 kW generated at the drum,"
        " the drive's losses 749 kW over the cycle, 89 % of them at points outside the drive"
        " model's domain, where it extrapolates (the 84.6 kW inside it alone would not make"
        " it draw: the draw rests on the extrapolation)")
    # a summary of before the loss share: the losses alone
    older = dict(key_warnings(summary.drop(columns="outside_domain_loss_frac")))
    assert older["drawing from the grid while generating"].endswith(
        "the drive's losses 749 kW over the cycle")
    quiet = summary.assign(avg_p_elec_w=-1.0, outside_domain_time_frac=0.1)
    assert key_warnings(quiet) == []


def test_every_drawing_cycle_is_explained_by_its_losses_in_section_4():
    # issue 49 (measured, MegAWES 6:12:3): mech-lim-6.0 and mech-free-6.0 both drew while
    # generating; the report gave the losses of the largest only. Truths by hand: losses
    # = P_elec - P_mech; the inside-domain share (1 - loss share) x losses against the
    # drum's generated power
    from reports.optimization_section import draw_rows, key_warnings

    summary = pd.DataFrame({
        "scenario": ["mech-free-6.0", "mech-lim-6.0", "mech-free-9.0", "elec-lim-9.0"],
        "kind": ["mech-free", "mech-lim", "mech-free", "elec-lim"],
        "wind_speed_m_s": [6.0, 6.0, 9.0, 9.0], "success": [True, True, True, True],
        "avg_p_elec_w": [65540.0, 65519.0, 20000.0, -50000.0],
        "avg_p_mech_w": [-255605.0, -255616.0, -100000.0, -80000.0],
        "outside_domain_time_frac": [0.632, 0.642, 0.1, 0.0],
        "outside_domain_loss_frac": [0.888, 0.893, 0.05, 0.0]})
    rows = draw_rows(summary)
    # each drawing cycle itemized, the largest losses first; the generating one not
    assert [r.split(":")[0] for r in rows] == ["mech-free-6.0", "mech-lim-6.0", "mech-free-9.0"]
    assert rows[1].startswith("mech-lim-6.0: 65.5 kW drawn, 256 kW generated at the drum, "
                              "the drive's losses 321 kW over the cycle, 89 % of them")
    # 0.107 x 321135 W = 34.4 kW inside: the draw rests on the extrapolation; mech-free-9.0:
    # 0.95 x 120 kW = 114 kW inside > 100 kW generated: it would draw without it too
    assert "(the 34.4 kW inside it alone would not make it draw" in rows[1]
    assert rows[2].endswith("(the 114 kW inside it alone would make it draw too)")
    # Key results: the largest, which ones rest on the extrapolation, where the rest are
    line = dict(key_warnings(summary))["drawing from the grid while generating"]
    assert line.startswith("3 converged cycles draw net power")
    assert "; largest mech-free-6.0: 65.5 kW drawn" in line
    assert ("the draws of mech-free at 6 m/s; mech-lim at 6 m/s rest on losses the model "
            "extrapolates") in line
    assert line.endswith("section 4 (optimized pumping cycles) gives each cycle's losses")
    assert draw_rows(summary.iloc[3:]) == []


def test_a_simulation_that_could_not_finish_is_a_failed_check_not_a_crash():
    # found by `bench run raw_measurements --system ap2.toml`: the report stopped with a
    # TypeError (float(None)) on AP2's elec-lim-17.5, whose simulation CVODES gave up on
    from reports.trust_checks import trust_checks

    record = {"scenario": "elec-lim-17.5", "integrator": "cvodes",
              "interval_defect_position_m": None, "open_loop_position_m": None,
              "periodicity_error_position_m": None,
              "verdict": "failed: the simulation could not finish (CV_TOO_MUCH_WORK)"}
    ok = {"scenario": "elec-lim-6.0", "integrator": "cvodes",
          "interval_defect_position_m": 1e-4, "open_loop_position_m": 0.1,
          "periodicity_error_position_m": 0.01}
    sim = trust_checks({"trust": {"simulation": [record, ok]}})["simulation"]
    assert sim["failed"] == 1
    assert sim["table"]["rows"][0][-1] == ("FAILS: the simulation could not finish "
                                           "(CV_TOO_MUCH_WORK)")
    assert "" not in sim["table"]["rows"][0] and "n/a" in sim["table"]["rows"][0]
