"""Readers, units and mappings on small hand-written files with known values."""

from __future__ import annotations

import math

import numpy as np
import pytest

from bench.ingest.column_units import split_header, unit_factor
from bench.ingest.csv_layout import sniff_csv
from bench.ingest.csv_stream import iter_csv
from bench.ingest.daq_stream import open_daq_csv, open_daq_tdms
from bench.ingest.mapping import load_mapping, resolve_columns
from bench.ingest.readers import read_analyzer
from kernel.errors import InputError


def test_unit_factors_by_hand():
    assert unit_factor("speed", "rad/s") == pytest.approx(60 / (2 * math.pi))
    for u in ("rpm", "1/min", "U/min", "min^-1", "MIN-1", " u / min "):
        assert unit_factor("speed", u) == 1.0
    assert unit_factor("torque", "kN m") == 1000.0
    assert unit_factor("torque", "N·m") == 1.0
    assert unit_factor("power", "kW") == 1000.0
    assert unit_factor("power", "MW") == 1e6
    assert unit_factor("time", "ms") == 1e-3
    assert unit_factor("speed", "rps") is None
    assert split_header("Torque [N m]") == ("Torque", "N m")
    assert split_header("P_sigma (kW)") == ("P_sigma", "kW")
    assert split_header("Drehzahl") == ("Drehzahl", None)


def _read(path, chunk_bytes=1 << 20):
    stream = open_daq_csv(path, chunk_bytes=chunk_bytes)
    parts = list(stream.chunks())
    return stream.metadata, {q: np.concatenate([p.values[q] for p in parts]) for q in
                             ("time", "speed", "torque")}, parts


def test_german_csv_with_units_row(tmp_path):
    p = tmp_path / "daq.csv"
    p.write_text("Zeit;Drehzahl;Drehmoment\ns;rad/s;kNm\n0,000;100,0;0,0125\n"
                 "0,020;---;9,91E+37\n0,040;;0,5\n", encoding="cp1252")
    meta, v, _ = _read(p)
    assert (meta["separator"], meta["decimal"]) == (";", ",")
    assert meta["columns"]["torque"] == {"column": "Drehmoment", "unit": "kNm"}
    np.testing.assert_allclose(v["time"], [0.0, 0.02, 0.04])
    # 100 rad/s = 954.93 rpm; 0.0125 kN m = 12.5 N m; markers and empty cell -> NaN
    np.testing.assert_allclose(v["speed"], [100 * 30 / math.pi, np.nan, np.nan])
    np.testing.assert_allclose(v["torque"], [12.5, np.nan, 500.0])


def test_chunk_boundaries_do_not_change_values(tmp_path):
    rng = np.random.default_rng(0)
    t = np.arange(5000) * 0.02
    s, q = rng.normal(1000, 5, t.size), rng.normal(40, 1, t.size)
    p = tmp_path / "daq.csv"
    rows = "\n".join(f"{a:.3f},{b:.3f},{c:.4f}" for a, b, c in zip(t, s, q, strict=True))
    p.write_text("Time [ms],Speed [rpm],Torque [N m]\n" + rows)  # no final newline
    _, big, _ = _read(p)
    _, small, parts = _read(p, chunk_bytes=1000)  # ~50 rows a chunk, lines cut at the edges
    assert len(parts) > 50
    assert [c.row0 for c in parts] == list(np.cumsum([0] + [c.values["time"].size
                                                            for c in parts[:-1]]))
    for k in big:
        np.testing.assert_array_equal(big[k], small[k])
    np.testing.assert_allclose(big["time"], np.round(t, 3) * 1e-3)  # ms -> s
    np.testing.assert_allclose(big["torque"], np.round(q, 4))


def test_analyzer_header_block_and_units_row(tmp_path):
    p = tmp_path / "analyzer.csv"
    p.write_text("Yokogawa;WT1800;Power Analyzer\nModel;WT1800\nStart Date;2013/04/18\n"
                 "Start Time;13:40:10.450\nSample Interval;100ms\n\n"
                 "Store No.;Zeit;Urms_sigma;P_sigma\n;s;V;kW\n1;0,000;399,9;0,880\n"
                 "2;0,100;400,0;NAN\n3;0,200;400,1;-1,250\n")
    frame, meta = read_analyzer(p)
    assert meta["start"] == "2013-04-18T13:40:10.450000"
    assert meta["header"]["Model"] == "WT1800"
    np.testing.assert_allclose(frame.time_s, [0.0, 0.1, 0.2])
    np.testing.assert_allclose(frame.p_elec_w, [880.0, np.nan, -1250.0])


def test_tdms_units_from_channel_properties(tmp_path):
    from nptdms import ChannelObject, TdmsWriter

    p = tmp_path / "daq.tdms"
    t = np.arange(10) * 0.02
    with TdmsWriter(p) as w:
        w.write_segment([
            ChannelObject("Messung", "Time", t, properties={"unit_string": "ms"}),
            ChannelObject("Messung", "Speed", np.full(10, 2 * math.pi),
                          properties={"unit_string": "rad/s"}),
            ChannelObject("Messung", "Torque", np.full(10, 0.05),
                          properties={"unit_string": "kN m"}),
        ])
    stream = open_daq_tdms(p, "Messung", chunk_rows=4)
    parts = list(stream.chunks())
    assert [c.row0 for c in parts] == [0, 4, 8]
    np.testing.assert_allclose(np.concatenate([c.values["speed"] for c in parts]), 60.0)
    np.testing.assert_allclose(np.concatenate([c.values["torque"] for c in parts]), 50.0)
    np.testing.assert_allclose(np.concatenate([c.values["time"] for c in parts]), t * 1e-3)
    with pytest.raises(InputError, match="no TDMS group 'Measurement'"):
        open_daq_tdms(p, "Measurement")


def test_mapping_toml_and_json_agree_and_reject_bad_entries(tmp_path):
    toml = tmp_path / "m.toml"
    toml.write_text('[daq.columns.speed]\ncolumn = "n_ist"\nunit = "U/min"\n')
    js = tmp_path / "m.json"
    js.write_text('{"daq": {"columns": {"speed": {"column": "n_ist", "unit": "U/min"}}}}')
    assert load_mapping(toml).sections == load_mapping(js).sections
    p = tmp_path / "daq.csv"
    p.write_text("t [s],n_ist,M [Nm]\n0.0,10,1\n0.1,11,2\n")
    layout = sniff_csv(p)
    cols = resolve_columns(p, layout.headers, layout.units_row, "daq",
                           ("time", "speed", "torque"), mapping=load_mapping(toml))
    assert (cols["speed"].index, cols["speed"].factor) == (1, 1.0)
    assert [c.values["speed"].tolist() for c in iter_csv(layout, cols)] == [[10.0, 11.0]]
    bad = tmp_path / "bad.toml"
    bad.write_text('[daq.columns.speed]\ncolumn = "n"\nunit = "rps"\n')
    with pytest.raises(InputError, match="unknown unit 'rps' for speed"):
        load_mapping(bad)
    bad.write_text('[daq.columns.voltage]\ncolumn = "U"\nunit = "V"\n')
    with pytest.raises(InputError, match=r"unknown quantity \[daq.columns.voltage\]"):
        load_mapping(bad)


def test_byte_order_mark_and_crlf(tmp_path):
    p = tmp_path / "daq.csv"
    p.write_bytes(b"\xef\xbb\xbfTime [s],Speed [rpm],Torque [N m]\r\n0.0,10,1\r\n0.1,11,2\r\n")
    meta, v, _ = _read(p)
    assert meta["columns"]["time"]["column"] == "Time [s]"
    np.testing.assert_array_equal(v["speed"], [10.0, 11.0])
    np.testing.assert_array_equal(v["time"], [0.0, 0.1])


def test_lines_longer_than_the_chunk_grow_the_buffer(tmp_path):
    """A chunk smaller than one line (here 8 bytes against lines of about 25): the buffer
    grows to hold the line and every value is read as with the default chunk."""
    p = tmp_path / "daq.csv"
    rows = "\n".join(f"{0.02 * k:.3f},{1000.0 + k:.3f},{40.0 + 0.01 * k:.4f}"
                     for k in range(200))
    p.write_text("Time [s],Speed [rpm],Torque [N m]\n" + rows + "\n")
    _, big, _ = _read(p)
    _, tiny, _ = _read(p, chunk_bytes=8)
    for k in big:
        np.testing.assert_array_equal(big[k], tiny[k])
    np.testing.assert_allclose(big["speed"], 1000.0 + np.arange(200))
