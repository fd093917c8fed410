"""Mapping features (sum, expr, units, skip_lines) and the point checks, on exports with a
known truth (tests/export_fixtures.py) and on broken variants of them (issue 10 findings 5,
8, 10; issue 13 section 2)."""

from __future__ import annotations

import math
import shutil

import numpy as np
import pandas as pd
import pytest
from ingest_fixtures import make_points_session, make_timeseries_session

from bench.ingest import expr
from bench.ingest.column_units import unit_factor
from bench.ingest.mapping import load_mapping
from bench.ingest.pipeline import ingest
from bench.store.manifest import kind_files
from bench.synth.exports import make_dyno_table, make_ev_table
from drivebench.cli import main
from kernel.errors import InputError


def _points(store, sid):
    pts = pd.read_parquet(kind_files(store, "points")[sid])
    return pts.sort_values("point_id").reset_index(drop=True)


def _cli_fails(tmp_path, capsys, campaign, *fragments):
    """Through the CLI: exit 2, each fragment in the message, no store written."""
    store = tmp_path / "store"
    rc = main(["ingest", str(campaign), "--store", str(store), "--no-progress"])
    err = capsys.readouterr().err
    assert rc == 2, err
    for f in fragments:
        assert f in err, (f, err)
    assert not (store / "manifest.json").exists()
    return err


def _set(path, old, new):
    text = path.read_text(encoding="utf-8")
    assert old in text, (old, path)
    path.write_text(text.replace(old, new), encoding="utf-8")


# --- the parser -------------------------------------------------------------------------

def test_expression_evaluates_like_numpy():
    cols = {"U [V]": np.array([400.0, 410.0]), "I [A]": np.array([10.0, -2.0]),
            "x": np.array([1.0, 0.0])}
    tree = expr.parse("{U [V]} * {I [A]} / 1e3 - -2 * ({x} + .5)")
    got = expr.evaluate(tree, cols.__getitem__)
    want = cols["U [V]"] * cols["I [A]"] / 1e3 + 2 * (cols["x"] + 0.5)
    np.testing.assert_allclose(got, want, rtol=1e-15)  # same operations, same order
    assert [c.name for c in expr.columns(tree)] == ["U [V]", "I [A]", "x"]
    # precedence and left associativity: 8 - 2 - 1 = 5, 8 / 2 / 2 = 2
    assert expr.evaluate(expr.parse("8 - 2 - 1 + 2 * 3"), None) == 11
    assert expr.evaluate(expr.parse("8 / 2 / 2"), None) == 2


@pytest.mark.parametrize("text, pos, words", [
    ("{U [V]} * ", 10, "at the end"),
    ("{U [V]} ** {I}", 9, "found '*'"),
    ("({U} + {I}", 10, "expected ')'"),
    ("{U} + {I", 6, "without a closing"),
    ("__import__('os')", 0, "unexpected character '_'"),
    ("{U} {I}", 4, "after a complete expression"),
    ("2 ^ 3", 2, "unexpected character '^'"),
])
def test_expression_syntax_errors_say_where(text, pos, words):
    with pytest.raises(expr.ExprError) as exc:
        expr.parse(text)
    assert exc.value.position == pos and words in str(exc.value)


# --- units ----------------------------------------------------------------------------

def test_units_case_carries_meaning():
    assert unit_factor("power", "mW") == 1e-3 and unit_factor("power", "MW") == 1e6
    assert unit_factor("power", "mw") is None  # milli or mega: refused, not guessed
    assert unit_factor("power", "KW") == 1e3  # no other unit spells kw
    assert unit_factor("torque", "N mm") == unit_factor("torque", "Nmm") == 1e-3
    assert unit_factor("torque", "mNm") == 1e-3 and unit_factor("torque", "MNm") == 1e6
    assert unit_factor("torque", "kN·m") == 1e3
    # 1 lbf ft = 4.4482216152605 N * 0.3048 m (exact definitions)
    assert unit_factor("torque", "lbf-ft") == pytest.approx(4.4482216152605 * 0.3048, rel=1e-12)
    assert unit_factor("speed", "RPM") == 1.0


def test_mapping_refuses_ambiguous_and_malformed_entries(tmp_path):
    m = tmp_path / "m.toml"
    for body, words in [
        ('[columns.p_elec]\ncolumn = "P"\nunit = "mw"\n', "ambiguous unit 'mw'"),
        ('[columns.p_elec]\nsum = ["P_1"]\nunit = "W"\n', "two or more column names"),
        ('[columns.p_elec]\ncolumn = "P"\nsum = ["A", "B"]\nunit = "W"\n', "exactly one of"),
        ('[columns.p_elec]\nexpr = "{U} * (2 + {I}"\nunit = "W"\n', "position 15"),
        ('[columns.p_elec]\nexpr = "3 * 4"\nunit = "W"\n', "names no column"),
        ('skip_lines = -1\n', "skip_lines"),
        ('[daq]\nskip_lines = 1.5\n', "daq.skip_lines"),
    ]:
        m.write_text(body)
        with pytest.raises(InputError) as exc:
            load_mapping(m)
        assert words in str(exc.value) and "m.toml" in str(exc.value), body


# --- fixtures with a known truth -------------------------------------------------------

def test_dyno_table_with_preamble_and_newton_millimetres(tmp_path):
    truth = make_dyno_table(tmp_path / "c")
    res = ingest([tmp_path / "c"], tmp_path / "store", progress=False)
    pts = _points(tmp_path / "store", "dyno_01")
    assert len(pts) == truth["speed_rpm"].size == 32 and res.ingested == ["dyno_01"]
    # printed to 0.1 rpm, 0.01 N mm (1e-5 N m) and 0.1 W: half of that is the worst rounding
    np.testing.assert_allclose(pts.speed_rpm, truth["speed_rpm"], atol=0.05 + 1e-9)
    np.testing.assert_allclose(pts.torque_nm, truth["torque_nm"], atol=0.5e-5 + 1e-12)
    np.testing.assert_allclose(pts.p_elec_w, truth["p_elec_w"], atol=0.05 + 1e-9)
    # p_mech is omega*T of the stored means (exact), within rounding of the truth's
    np.testing.assert_allclose(pts.p_mech_w, pts.speed_rpm * pts.torque_nm * math.pi / 30)
    assert (pts.quadrant.value_counts() == [16, 16]).all()
    man = res.manifest["sessions"]["dyno_01"]
    assert man["instruments"]["points"]["columns"]["torque"] == {"column": "Moment [N mm]",
                                                                 "unit": "N mm"}


def test_dyno_table_without_skip_lines_says_so(tmp_path, capsys):
    make_dyno_table(tmp_path / "c")
    _set(tmp_path / "c" / "dyno_01" / "mapping.toml", "skip_lines = 2", "")
    _cli_fails(tmp_path, capsys, tmp_path / "c", "'Moment [N mm]'", "column row read is line 1",
               "skip_lines")


@pytest.mark.parametrize("p_elec_by", ["expr", "sum"])
def test_ev_export_with_500_columns(tmp_path, p_elec_by):
    truth = make_ev_table(tmp_path / "c", p_elec_by=p_elec_by)
    ingest([tmp_path / "c"], tmp_path / "store", progress=False)
    pts = _points(tmp_path / "store", "ev_01")
    assert len(pts) == 96
    assert (pts.quadrant == np.where(truth["speed_rpm"] > 0, "motor", "generator")).all()
    np.testing.assert_allclose(pts.speed_rpm, truth["speed_rpm"], atol=0.005 + 1e-9)
    np.testing.assert_allclose(pts.torque_nm, truth["torque_nm"], atol=0.0005 + 1e-9)
    if p_elec_by == "expr":
        # U printed to 1 mV (<= 1.3e-6 relative at 400 V), I to 0.1 mA: |dP| <= 0.5e-3 * I
        # + 0.5e-4 * U  (<= 0.6 W at 375 A)
        tol = 0.5e-3 * np.abs(truth["p_elec_w"] / truth["u_dc_v"]) + 0.5e-4 * truth["u_dc_v"]
    else:
        tol = np.full(96, 3 * 0.5e-5 * 1e3)  # three kW values rounded to 0.01 W each
    assert np.all(np.abs(pts.p_elec_w - truth["p_elec_w"]) <= tol + 1e-9)
    # p_mech is the mapped P_Mech [kW] (5 decimals: 0.005 W), not the setpoint column
    np.testing.assert_allclose(pts.p_mech_w, truth["p_mech_w"], atol=0.005 + 1e-9)


def test_expr_naming_an_unknown_column_lists_the_closest_few(tmp_path, capsys):
    make_ev_table(tmp_path / "c")
    _set(tmp_path / "c" / "ev_01" / "mapping.toml", "{I_DC [A]}", "{I_DCLink [A]}")
    err = _cli_fails(tmp_path, capsys, tmp_path / "c", "mapping.toml", "'I_DCLink [A]'",
                     "'I_DC [A]'", "and 494 more")
    assert err.count("Aux_") <= 6  # never the 500 names


def test_missing_column_among_500_lists_the_closest_few(tmp_path, capsys):
    make_ev_table(tmp_path / "c")
    _set(tmp_path / "c" / "ev_01" / "mapping.toml",
         '[columns.speed]\ncolumn = "Speed [rpm]"\nunit = "rpm"\n', "")
    _set(tmp_path / "c" / "ev_01" / "export.csv", "Speed [rpm]", "Rotor_Speed [rpm]")
    err = _cli_fails(tmp_path, capsys, tmp_path / "c", "missing column for speed",
                     "'Rotor_Speed [rpm]'", "and 494 more")
    assert len(err) < 1500


# --- wrong units and columns: each a clear error, exit 2 --------------------------------

def test_kilonewton_metres_that_are_newton_metres(tmp_path, capsys):
    make_ev_table(tmp_path / "c")
    _set(tmp_path / "c" / "ev_01" / "mapping.toml", 'unit = "Nm"', 'unit = "kNm"')
    _cli_fails(tmp_path, capsys, tmp_path / "c", "export.csv", "'Torque_Flange [Nm]'",
               "above the torque sensor range 400 N m", "suspect the torque unit",
               "looks like N m")


def test_watt_column_holding_kilowatts(tmp_path, capsys):
    """The issue-13 case: P [W] holds kW, so motor efficiency reads in the hundreds."""
    make_dyno_table(tmp_path / "c")
    path = tmp_path / "c" / "dyno_01" / "points.txt"
    lines = path.read_text(encoding="utf-8").splitlines()
    out = lines[:3]
    for ln in lines[3:]:
        cells = ln.split("\t")
        cells[3] = f"{float(cells[3]) / 1e3:.5f}"
        out.append("\t".join(cells))
    path.write_text("\n".join(out) + "\n", encoding="utf-8")
    _cli_fails(tmp_path, capsys, tmp_path / "c", "'P_el [W]'", "efficiency above 1",
               "suspect the p_elec unit", "looks like kW")


def test_megawatt_for_milliwatt_is_out_of_range(tmp_path, capsys):
    make_dyno_table(tmp_path / "c")
    _set(tmp_path / "c" / "dyno_01" / "points.txt", "P_el [W]", "P_el [mW]")
    path = tmp_path / "c" / "dyno_01" / "points.txt"
    lines = path.read_text(encoding="utf-8").splitlines()
    out = lines[:3] + ["\t".join(c if i != 3 else f"{float(c) * 1e3:.1f}"
                                 for i, c in enumerate(ln.split("\t"))) for ln in lines[3:]]
    path.write_text("\n".join(out) + "\n", encoding="utf-8")
    _set(tmp_path / "c" / "dyno_01" / "mapping.toml", 'column = "P_el [W]"\nunit = "W"',
         'column = "P_el [mW]"\nunit = "MW"')
    _cli_fails(tmp_path, capsys, tmp_path / "c", "above the power sensor range",
               "suspect the p_elec unit", "looks like mW")


def test_one_column_for_speed_and_torque(tmp_path, capsys):
    make_ev_table(tmp_path / "c")
    _set(tmp_path / "c" / "ev_01" / "mapping.toml", 'column = "Torque_Flange [Nm]"',
         'column = "Speed [rpm]"')
    _cli_fails(tmp_path, capsys, tmp_path / "c", "mapping.toml", "'Speed [rpm]'",
               "taken for both speed and torque")


def test_mapped_p_mech_that_is_not_omega_t(tmp_path, capsys):
    make_ev_table(tmp_path / "c")
    _set(tmp_path / "c" / "ev_01" / "mapping.toml", 'column = "P_Mech [kW]"',
         'column = "P_Mech_Setpoint [kW]"')
    _cli_fails(tmp_path, capsys, tmp_path / "c", "'P_Mech_Setpoint [kW]'",
               "disagrees with omega*T", "median ratio 0.9")


def test_p_mech_column_is_never_taken_unless_mapped(tmp_path):
    """A header that looks like p_mech but holds something else (a swapped column) is
    ignored without a mapping entry: p_mech is omega*T."""
    make_dyno_table(tmp_path / "c")
    _set(tmp_path / "c" / "dyno_01" / "points.txt", "T_Wicklung [°C]", "P_mech [W]")
    ingest([tmp_path / "c"], tmp_path / "store", progress=False)
    pts = _points(tmp_path / "store", "dyno_01")
    np.testing.assert_allclose(pts.p_mech_w, pts.speed_rpm * pts.torque_nm * math.pi / 30)


@pytest.mark.parametrize("value, words", [(lambda k: "0.0", "zero throughout"),
                                          (lambda k: "1234.5", "one value (1234.5)")])
def test_zero_or_constant_p_elec(tmp_path, capsys, value, words):
    make_dyno_table(tmp_path / "c")
    path = tmp_path / "c" / "dyno_01" / "points.txt"
    lines = path.read_text(encoding="utf-8").splitlines()
    out = lines[:3] + ["\t".join(c if i != 3 else value(k) for i, c in enumerate(ln.split("\t")))
                       for k, ln in enumerate(lines[3:])]
    path.write_text("\n".join(out) + "\n", encoding="utf-8")
    _cli_fails(tmp_path, capsys, tmp_path / "c", "'P_el [W]'", words)


def test_a_single_implausible_point_is_rejected_with_its_reason(tmp_path):
    truth = make_dyno_table(tmp_path / "c")
    path = tmp_path / "c" / "dyno_01" / "points.txt"
    lines = path.read_text(encoding="utf-8").splitlines()
    cells = lines[3].split("\t")
    cells[3] = f"{float(cells[3]) * 0.5:.1f}"  # motor row: p_elec half of p_mech
    lines[3] = "\t".join(cells)
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    ingest([tmp_path / "c"], tmp_path / "store", progress=False)
    assert len(_points(tmp_path / "store", "dyno_01")) == truth["speed_rpm"].size - 1
    rej = pd.read_parquet(kind_files(tmp_path / "store", "rejected")["dyno_01"])
    assert rej.reason.tolist() == ["efficiency above 1"]


@pytest.mark.parametrize("mode, words", [("motor", "efficiency above 1"),
                                         ("generator", "below 5% of |omega*T| at high power")])
def test_timeseries_analyzer_watt_column_holding_kilowatts(tmp_path, capsys, mode, words):
    """Motor mode: efficiency in the hundreds; generator mode: efficiency near 0, which
    losses alone allow, so the session-wide test must catch it."""
    make_timeseries_session(tmp_path / "c", "s_01", mode=mode, power_unit="kW")
    _set(tmp_path / "c" / "s_01" / "analyzer.csv", "P_sigma [kW]", "P_sigma [W]")
    _cli_fails(tmp_path, capsys, tmp_path / "c", "analyzer.csv", "'P_sigma [W]'", words,
               "suspect the p_elec unit", "looks like kW")


def test_torque_sign_the_data_cannot_decide(tmp_path, capsys):
    """Half the high-power rows disagree in sign: flipping would not help, and the message
    must not suggest it."""
    make_points_session(tmp_path / "c", n=40)
    path = tmp_path / "c" / "table_01" / "points.csv"
    lines = path.read_text().splitlines()
    for k in range(1, len(lines), 2):  # every other row: p_elec negated
        cells = lines[k].split(";")
        cells[2] = cells[2][1:] if cells[2].startswith("-") else "-" + cells[2]
        lines[k] = ";".join(cells)
    path.write_text("\n".join(lines) + "\n")
    err = _cli_fails(tmp_path, capsys, tmp_path / "c", "cannot decide the torque sign")
    assert "torque_sign = -1" not in err


def test_daq_section_sum_in_a_timeseries_session(tmp_path):
    """``sum`` works for stream sections too: torque logged as two half-bridges."""
    truth = make_timeseries_session(tmp_path / "c", "motor_01", markers=False)
    daq = tmp_path / "c" / "motor_01" / "daq.csv"
    lines = daq.read_text().splitlines()
    out = ["Time [s],Speed [1/min],M_a [N m],M_b [N m]"]
    for ln in lines[1:]:
        t, s, q = ln.split(",")
        out.append(f"{t},{s},{float(q) * 0.25!r},{float(q) * 0.75!r}")
    daq.write_text("\n".join(out) + "\n")
    (tmp_path / "c" / "motor_01" / "mapping.toml").write_text(
        '[daq.columns.torque]\nsum = ["M_a [N m]", "M_b [N m]"]\nunit = "N m"\n')
    ingest([tmp_path / "c"], tmp_path / "store", progress=False)
    pts = _points(tmp_path / "store", "motor_01")
    assert len(pts) == len(truth.setpoints)
    # torque noise 0.15 N m per sample, >= 200 samples a window: 5 sigma < 0.06 N m
    np.testing.assert_allclose(pts.torque_nm, [q for _, q in truth.setpoints], atol=0.06)


def test_store_left_alone_by_a_failing_check(tmp_path, capsys):
    make_dyno_table(tmp_path / "c")
    store = tmp_path / "store"
    assert main(["ingest", str(tmp_path / "c"), "--store", str(store), "--no-progress"]) == 0
    before = {p: p.read_bytes() for p in store.rglob("*") if p.is_file()}
    shutil.rmtree(tmp_path / "c" / "dyno_01")
    make_dyno_table(tmp_path / "c")
    _set(tmp_path / "c" / "dyno_01" / "mapping.toml", 'unit = "N mm"', 'unit = "N m"')
    rc = main(["ingest", str(tmp_path / "c"), "--store", str(store), "--no-progress"])
    assert rc == 2 and "suspect the torque unit" in capsys.readouterr().err
    assert {p: p.read_bytes() for p in store.rglob("*") if p.is_file()} == before


def test_title_line_above_a_daq_header_is_named(tmp_path, capsys):
    """A DAQ stream whose first line is a title: the error says so and how to skip it;
    with ``[daq] skip_lines = 1`` the session reads as without the title."""
    make_timeseries_session(tmp_path / "c", "motor_01", markers=False)
    daq = tmp_path / "c" / "motor_01" / "daq.csv"
    daq.write_text("Prüfstand 2 Messung 17.04.2013\n" + daq.read_text(), encoding="utf-8")
    _cli_fails(tmp_path, capsys, tmp_path / "c", "daq.csv:1", "a title or date line",
               "skip_lines")
    (tmp_path / "c" / "motor_01" / "mapping.toml").write_text("[daq]\nskip_lines = 1\n")
    res = ingest([tmp_path / "c"], tmp_path / "store", progress=False)
    assert res.manifest["sessions"]["motor_01"]["n_points"] == 6


def test_tdms_channels_combined_by_expr(tmp_path):
    """``expr`` over TDMS channels: torque from a strain-gauge voltage [mV] and a gain."""
    from nptdms import ChannelObject, TdmsWriter

    from bench.ingest.daq_stream import open_daq_tdms

    p = tmp_path / "daq.tdms"
    t = np.arange(10) * 0.01
    u_mv = np.linspace(1.0, 2.0, 10)
    with TdmsWriter(p) as w:
        w.write_segment([
            ChannelObject("G", "Time", t, properties={"unit_string": "s"}),
            ChannelObject("G", "Speed", np.full(10, 600.0), properties={"unit_string": "rpm"}),
            ChannelObject("G", "Bridge", u_mv, properties={"unit_string": "mV"}),
        ])
    m = tmp_path / "mapping.toml"
    m.write_text('[daq.columns.torque]\nexpr = "({Bridge} - 0.5) * 40"\nunit = "N mm"\n')
    parts = list(open_daq_tdms(p, "G", load_mapping(m), chunk_rows=3).chunks())
    got = np.concatenate([c.values["torque"] for c in parts])
    np.testing.assert_allclose(got, (u_mv - 0.5) * 40 * 1e-3, rtol=1e-14)  # N mm -> N m


def test_mapped_names_match_without_regard_to_case_and_spacing(tmp_path):
    from pathlib import Path

    from bench.ingest.mapping import resolve_columns

    m = tmp_path / "m.toml"
    m.write_text('[columns.speed]\ncolumn = "motor  speed [RPM]"\nunit = "rpm"\n'
                 '[columns.torque]\ncolumn = "torque"\nunit = "N m"\n'
                 '[columns.p_elec]\nsum = ["p_1 [w]", "P_2 [W]"]\nunit = "W"\n')
    headers = ["Motor Speed [rpm]", "Torque [Nm]", "P_1 [W]", "P_2 [W]"]
    got = resolve_columns(Path("x.csv"), headers, None, "points",
                          ("speed", "torque", "p_elec"), mapping=load_mapping(m))
    assert got["speed"].index == 0 and got["torque"].index == 1
    assert got["p_elec"].indices == (2, 3)


@pytest.mark.parametrize("old, new, words", [
    ('expr = "{U_DC [V]} * {I_DC [A]}"', 'expr = "{U_DC [V]} * * {I_DC [A]}"',
     ["position 14", "found '*'"]),
    ('unit = "W"', 'unit = "mw"', ["ambiguous unit 'mw'"]),
])
def test_bad_mapping_entries_exit_2_through_the_cli(tmp_path, capsys, old, new, words):
    make_ev_table(tmp_path / "c")
    _set(tmp_path / "c" / "ev_01" / "mapping.toml", old, new)
    _cli_fails(tmp_path, capsys, tmp_path / "c", "mapping.toml", "columns.p_elec", *words)
