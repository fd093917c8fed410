"""Hostile and unlucky inputs that gave tracebacks or misleading messages: each is exit 2
naming the file and the key or line (bench ingest, bench report)."""

from __future__ import annotations

import builtins
import os

import pytest
from ingest_fixtures import make_timeseries_session

from bench.ingest import scan
from bench.ingest.expr import ExprError, parse
from bench.store.read import read_points
from drivebench.cli import main


@pytest.fixture
def camp(tmp_path):
    make_timeseries_session(tmp_path / "camp", "motor_01", seed=1)
    return tmp_path / "camp"


def _ingest(camp, store, capsys):
    rc = main(["ingest", str(camp), "--store", str(store), "--no-progress"])
    return rc, capsys.readouterr().err


def _edit(path, old, new):
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new))


def test_disk_full_while_writing_samples_names_the_store(camp, tmp_path, capsys,
                                                         monkeypatch):
    """numpy's tofile on a full disk raised "N requested and M written" (no errno):
    now exit 2 naming the store, nothing committed."""
    def full_disk(path, mode):  # the scratch file is created, its writes go to /dev/full
        fh = builtins.open(path, mode)
        fd = os.open("/dev/full", os.O_WRONLY)
        os.dup2(fd, fh.fileno())
        os.close(fd)
        return fh

    monkeypatch.setattr(scan, "open", full_disk, raising=False)
    store = tmp_path / "store"
    rc, err = _ingest(camp, store, capsys)
    assert rc == 2 and "Traceback" not in err
    assert str(store) in err and "disk is probably full" in err
    assert not (store / "manifest.json").exists()


@pytest.mark.parametrize("value", ["1e6", "1e30"])
def test_daq_torque_spike_is_named_at_its_line(camp, tmp_path, capsys, value):
    """One torque sample of 1e6 N m (or a 4 s block of 1e30) in daq.csv was blamed on
    analyzer.csv; now the DAQ file and the spike's line are named."""
    daq = camp / "motor_01" / "daq.csv"
    lines = daq.read_text().splitlines()
    rows = [2000] if value == "1e6" else range(2000, 2400)
    for k in rows:
        t, s, _ = lines[k].split(",")
        lines[k] = f"{t},{s},{value}"
    daq.write_text("\n".join(lines) + "\n")
    store = tmp_path / "store"
    rc, err = _ingest(camp, store, capsys)
    assert "analyzer power does not follow" not in err
    if rc == 0:  # the spike's windows rejected, no point holds it
        assert read_points(store)["torque_nm"].abs().max() < 200.0
    else:
        assert rc == 2 and "daq.csv:2001" in err and "spike" in err


def test_report_on_a_bit_rotted_store(camp, tmp_path, capsys):
    store = tmp_path / "store"
    assert _ingest(camp, store, capsys)[0] == 0
    points = next(store.glob("gen-*/points/motor_01.parquet"))
    data = bytearray(points.read_bytes())
    for k in range(8, len(data) - 8, 7):
        data[k] ^= 0xFF
    points.write_bytes(bytes(data))
    rc = main(["report", "--store", str(store), "--fit", str(tmp_path / "nofit"),
               "--optimize", str(tmp_path / "noopt"), "--out", str(tmp_path / "r.html")])
    err = capsys.readouterr().err
    assert rc == 2 and "damaged store" in err and "motor_01" in err
    assert not (tmp_path / "r.html").exists()


@pytest.mark.parametrize("name", ["session.toml", "mapping.toml"])
def test_file_linking_out_of_the_session_folder(camp, tmp_path, capsys, name):
    outside = tmp_path / "elsewhere.toml"
    session = camp / "motor_01"
    if name == "session.toml":
        outside.write_text((session / name).read_text())
        (session / name).unlink()
    else:
        outside.write_text("")
    (session / name).symlink_to(outside)
    rc, err = _ingest(camp, tmp_path / "store", capsys)
    assert rc == 2 and "link out of the session folder" in err and name in err


def test_session_folder_linking_out_of_the_campaign_is_named(camp, tmp_path, capsys):
    other = tmp_path / "other"
    make_timeseries_session(other, "gen_01", mode="generator", seed=2)
    (camp / "gen_01").symlink_to(other / "gen_01")
    rc, err = _ingest(camp, tmp_path / "store", capsys)
    assert rc == 0
    assert "skipped" in err and "gen_01" in err and "link out of" in err


def test_fifo_named_session_toml(camp, tmp_path, capsys):
    """A FIFO named session.toml hung ingest (open waits for a writer)."""
    session = camp / "motor_01"
    (session / "session.toml").unlink()
    os.mkfifo(session / "session.toml")
    rc, err = _ingest(camp, tmp_path / "store", capsys)
    assert rc == 2 and "not a regular file" in err and "session.toml" in err


@pytest.mark.parametrize(("old", "new", "key", "words"), [
    ('notes = "fixture"', "notes = nan", "notes", "non-finite number nan"),
    ("gear_ratio = 3.0", "gear_ratio = " + "9" * 400, "gear_ratio", "400 digits"),
    ("torque_range_nm = 100.0", "torque_range_nm = " + "1" * 400, "sensors.torque_range_nm",
     "400 digits"),
])
def test_numbers_no_float_holds(camp, tmp_path, capsys, old, new, key, words):
    """notes = nan blamed manifest.json; a 400-digit integer raised OverflowError. Now
    session.toml and the key are named."""
    _edit(camp / "motor_01" / "session.toml", old, new)
    rc, err = _ingest(camp, tmp_path / "store", capsys)
    assert rc == 2 and "Traceback" not in err
    assert "session.toml" in err and f"column {key!r}" in err and words in err


@pytest.mark.parametrize("text", ["(" * 400 + "{a}" + ")" * 400,
                                  " + ".join(["{a}"] * 2000),
                                  "-" * 5000 + "{a}"])
def test_expression_too_deep_or_long(text):
    """400 nested parentheses or 2000 terms raised RecursionError: now a syntax error
    with its position."""
    with pytest.raises(ExprError) as err:
        parse(text)
    assert "more than" in str(err.value)


def test_deep_expression_in_a_mapping_names_the_key(camp, tmp_path, capsys):
    deep = "(" * 400 + "{Torque}" + ")" * 400
    (camp / "motor_01" / "mapping.toml").write_text(
        f'[daq.columns]\ntorque = {{ expr = "{deep}", unit = "N m" }}\n')
    rc, err = _ingest(camp, tmp_path / "store", capsys)
    assert rc == 2 and "mapping.toml" in err and "torque.expr" in err
    assert "more than" in err
