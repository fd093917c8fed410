"""Hostile or broken inputs of issue 13: each gives a clear InputError naming the file and
line or key, exit code 2, and leaves the store byte for byte as it was (or, where the
input is valid after all, is read correctly)."""

from __future__ import annotations

import json
import os
import shutil

import pytest
from ingest_fixtures import make_points_session, make_timeseries_session, store_tree

from bench.ingest.csv_layout import MAX_LINE_BYTES
from bench.store.manifest import read_manifest
from bench.store.read import read_points
from drivebench.cli import main


def _ingest(store_and_campaign, capsys, *extra):
    good, camp, store = store_and_campaign
    rc = main(["ingest", str(good), str(camp), "--store", str(store), "--no-progress",
               *extra])
    out = capsys.readouterr()
    return rc, out.err


def _fails(store_and_campaign, capsys, *fragments, extra=()):
    """Exit 2, every fragment in the message, the store untouched."""
    before = store_tree(store_and_campaign[2])
    rc, err = _ingest(store_and_campaign, capsys, *extra)
    assert rc == 2, err
    assert "Traceback" not in err
    for f in fragments:
        assert f in err, (f, err)
    assert store_tree(store_and_campaign[2]) == before
    return err


def _toml(store_and_campaign, old, new):
    path = store_and_campaign[1] / "bad_01" / "session.toml"
    text = path.read_text()
    assert old in text
    path.write_text(text.replace(old, new))


def _daq(store_and_campaign):
    return store_and_campaign[1] / "bad_01" / "daq.csv"


# -- session.toml ------------------------------------------------------------------------
def test_unquoted_toml_date_is_stored_as_iso_text(store_and_campaign, capsys):
    """TOML has dates; the manifest stores them as ISO 8601 text (was: a traceback after
    the data files had moved)."""
    _toml(store_and_campaign, 'date = "2013-04-17"', "date = 2013-04-17\nstart_time = 09:12:03")
    rc, err = _ingest(store_and_campaign, capsys)
    assert rc == 0, err
    meta = read_manifest(store_and_campaign[2])["sessions"]["bad_01"]["metadata"]
    assert meta["date"] == "2013-04-17" and meta["start_time"] == "09:12:03"


def test_sensors_not_a_table(store_and_campaign, capsys):
    _toml(store_and_campaign, 'session_id = "bad_01"', 'sensors = "none"\nsession_id = "bad_01"')
    _toml(store_and_campaign, "[sensors]", "[other]")
    _fails(store_and_campaign, capsys, "bad_01/session.toml", "column 'sensors'", "[sensors] table")


@pytest.mark.parametrize("value", ['"abc"', "0", "-100.0", "nan", "inf", "true"])
def test_bad_sensor_range(store_and_campaign, capsys, value):
    """Zero, negative, NaN, infinite, text: refused before NaN could reach manifest.json."""
    _toml(store_and_campaign, "torque_range_nm = 100.0", f"torque_range_nm = {value}")
    _fails(store_and_campaign, capsys, "bad_01/session.toml", "column 'sensors.torque_range_nm'",
           "finite positive number")


def test_infinite_gear_ratio(store_and_campaign, capsys):
    """Blamed on session.toml's key (was: on the analyzer file)."""
    _toml(store_and_campaign, "gear_ratio = 3.0", "gear_ratio = inf")
    _fails(store_and_campaign, capsys, "bad_01/session.toml", "column 'gear_ratio'",
           "finite positive")


@pytest.mark.parametrize("how", ["absolute", "climbing", "symlink"])
def test_data_file_outside_the_session_folder(store_and_campaign, capsys, tmp_path, how):
    """Refused before it is opened; the target's content is never echoed."""
    secret = tmp_path / "secret.txt"
    secret.write_text("SECRET-FIRST-LINE,1,2\n1,2,3\n")
    if how == "absolute":
        name = str(secret)
    elif how == "climbing":
        name = "../../secret.txt"
    else:
        os.symlink(secret, store_and_campaign[1] / "bad_01" / "link.csv")
        name = "link.csv"
    _toml(store_and_campaign, 'file = "daq.csv"', f'file = "{name}"')
    err = _fails(store_and_campaign, capsys, "bad_01/session.toml", "column 'daq.file'",
                 "outside the session folder" if how != "symlink" else "link out of")
    assert "SECRET" not in err


def test_symlink_cycle_and_links_out_of_the_campaign(store_and_campaign, capsys, tmp_path):
    """Discovery ends on a link cycle and does not follow a link out of the campaign."""
    good, camp, store = store_and_campaign
    os.symlink(camp, camp / "loop")  # camp/loop -> camp
    outside = tmp_path / "elsewhere"
    make_timeseries_session(outside, "foreign_01", seed=3)
    os.symlink(outside, camp / "out")
    rc, err = _ingest(store_and_campaign, capsys)
    assert rc == 0, err
    assert sorted(read_manifest(store)["sessions"]) == ["bad_01", "good_01"]


def test_session_of_another_source_is_named_or_refused(store_and_campaign, capsys, tmp_path):
    good, camp, store = store_and_campaign
    other = tmp_path / "other"
    make_timeseries_session(other, "good_01", seed=11)  # same id, other data and folder
    before = store_tree(store)
    rc = main(["ingest", str(other), "--store", str(store), "--no-progress", "--no-replace"])
    err = capsys.readouterr().err
    assert rc == 2 and "'good_01'" in err and str(good / "good_01") in err
    assert store_tree(store) == before
    rc = main(["ingest", str(other), "--store", str(store), "--no-progress"])
    err = capsys.readouterr().err
    assert rc == 0
    assert f"replacing stored session 'good_01' (from {good / 'good_01'})" in err
    assert read_manifest(store)["sessions"]["good_01"]["source"] == str(other / "good_01")


def test_count_column_of_3e9_does_not_wrap(tmp_path, capsys):
    root = tmp_path / "camp"
    make_points_session(root, "table_01")
    path = root / "table_01" / "points.csv"
    lines = path.read_text().splitlines()
    lines[1] = ";".join(lines[1].split(";")[:-1] + ["3000000000"])
    path.write_text("\n".join(lines) + "\n")
    store = tmp_path / "store"
    assert main(["ingest", str(root), "--store", str(store), "--no-progress"]) == 0
    pts = read_points(store)
    assert pts["n_samples"].max() == 3_000_000_000
    lines[2] = ";".join(lines[2].split(";")[:-1] + ["-4"])
    path.write_text("\n".join(lines) + "\n")
    assert main(["ingest", str(root), "--store", str(store), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert "points.csv:3" in err and "column 'N'" in err and "bad sample count" in err


def test_manifest_is_strict_json(store_and_campaign):
    """json.loads with NaN/Infinity refused reads every manifest ingest writes."""
    text = (store_and_campaign[2] / "manifest.json").read_text()
    json.loads(text, parse_constant=lambda c: pytest.fail(f"{c} in manifest.json"))


# -- DAQ files -------------------------------------------------------------------------
def test_header_and_one_row(store_and_campaign, capsys):
    daq = _daq(store_and_campaign)
    daq.write_text("\n".join(daq.read_text().splitlines()[:2]) + "\n")
    _fails(store_and_campaign, capsys, "bad_01/daq.csv", "only 1 data row(s)")


@pytest.mark.parametrize("line", [2, 500])
def test_60_mb_cell(store_and_campaign, capsys, line):
    """A 60 MB cell is named at its line, read only up to the 1 MiB line bound."""
    daq = _daq(store_and_campaign)
    lines = daq.read_bytes().split(b"\n")
    lines[line - 1] = b"1" * (60 << 20)
    daq.write_bytes(b"\n".join(lines))
    _fails(store_and_campaign, capsys, f"bad_01/daq.csv:{line}:",
           f"line longer than {MAX_LINE_BYTES // 1024} KiB")


def test_german_file_with_one_english_line(store_and_campaign, capsys, tmp_path):
    """The message names the offending line (was: line 3, the first data row)."""
    shutil.rmtree(store_and_campaign[1] / "bad_01")
    make_timeseries_session(store_and_campaign[1], "bad_01", seed=7, locale="de")
    daq = _daq(store_and_campaign)
    lines = daq.read_text().splitlines()
    assert lines[1].startswith("s;")  # names, units, then data from line 3
    lines[1800] = lines[1800].replace(",", ".")  # line 1801 in English decimals
    daq.write_text("\n".join(lines) + "\n")
    _fails(store_and_campaign, capsys, "bad_01/daq.csv:1801:", "not a number", "decimal mark ','")


def test_utf16_file(store_and_campaign, capsys):
    daq = _daq(store_and_campaign)
    daq.write_bytes(daq.read_text().encode("utf-16"))
    _fails(store_and_campaign, capsys, "bad_01/daq.csv:1:", "UTF-16", "re-saved as UTF-8")


def test_cr_only_line_ends(store_and_campaign, capsys):
    daq = _daq(store_and_campaign)
    daq.write_bytes(daq.read_bytes().replace(b"\n", b"\r"))
    _fails(store_and_campaign, capsys, "bad_01/daq.csv:1:", "CR only", "LF or CRLF")


def test_names_row_over_64_kib_is_read(store_and_campaign, capsys):
    """3500 extra channels make an 80 KiB names row (was: "no column row"); the points
    are those of the file without them."""
    daq = _daq(store_and_campaign)
    lines = daq.read_bytes().split(b"\n")
    extra_names = b"".join(b",Extra channel %04d [V]" % k for k in range(3500))
    lines = [ln + (extra_names if i == 0 else b",0.5" * 3500) if ln else ln
             for i, ln in enumerate(lines)]
    assert len(lines[0]) > 64 * 1024
    daq.write_bytes(b"\n".join(lines))
    rc, err = _ingest(store_and_campaign, capsys)
    assert rc == 0, err
    wide = read_points(store_and_campaign[2]).query("session_id == 'bad_01'").reset_index(drop=True)
    ref_store = store_and_campaign[2].parent / "ref"
    ref = store_and_campaign[2].parent / "ref_camp"
    make_timeseries_session(ref, "bad_01", seed=7)
    assert main(["ingest", str(ref), "--store", str(ref_store), "--no-progress"]) == 0
    narrow = read_points(ref_store)
    assert wide[["speed_rpm", "torque_nm", "p_elec_w"]].equals(
        narrow[["speed_rpm", "torque_nm", "p_elec_w"]])


def test_time_value_of_1e9_s(store_and_campaign, capsys):
    """Named at its line before any grid is sized (was: allocating 74.5 GiB)."""
    daq = _daq(store_and_campaign)
    lines = daq.read_text().splitlines()
    n = len(lines)
    lines[-1] = "1000000000.0," + lines[-1].split(",", 1)[1]
    daq.write_text("\n".join(lines) + "\n")
    _fails(store_and_campaign, capsys, f"bad_01/daq.csv:{n}:", "column 'Time [s]'", "time jumps",
           "1e+09 s")



# -- output folders ----------------------------------------------------------------------
def _read_only(monkeypatch, folder):
    """Make ``folder`` unwritable: chmod for a normal user; root ignores modes, so there
    file creation under it fails as on a read-only mount (EROFS)."""
    if os.geteuid() != 0:
        folder.chmod(0o555)
        return
    import errno
    import tempfile

    real = tempfile.mkstemp
    real_open = os.open

    def mkstemp(*a, dir=None, **kw):
        if dir is not None and str(dir).startswith(str(folder)):
            raise OSError(errno.EROFS, "Read-only file system", str(dir))
        return real(*a, dir=dir, **kw)

    def os_open(path, flags, *a, **kw):
        if str(path).startswith(str(folder)) and flags & (os.O_WRONLY | os.O_RDWR):
            raise OSError(errno.EROFS, "Read-only file system", str(path))
        return real_open(path, flags, *a, **kw)

    monkeypatch.setattr(tempfile, "mkstemp", mkstemp)
    monkeypatch.setattr(os, "open", os_open)


def test_fit_out_naming_an_existing_file(tmp_path, capsys, monkeypatch):
    """Refused before the fit (was: after the whole fit)."""
    from fitting import pipeline

    def no_fit(*a, **kw):
        raise AssertionError("the fit ran")

    monkeypatch.setattr(pipeline, "load_points", no_fit)  # the fit's first step
    out = tmp_path / "fit_out"
    out.write_text("keep me")
    rc = main(["fit", "--store", str(tmp_path / "store"), "--out", str(out)])
    err = capsys.readouterr().err
    assert rc == 2 and "fit_out: option --out: exists and is not a folder" in err
    assert out.read_text() == "keep me"


@pytest.mark.parametrize("stage", ["fit", "optimize", "report", "ingest"])
def test_read_only_output_folder(tmp_path, capsys, monkeypatch, stage):
    ro = tmp_path / "ro"
    ro.mkdir()
    camp = tmp_path / "camp"
    make_timeseries_session(camp, "s_01")
    _read_only(monkeypatch, ro)
    argv = {"fit": ["fit", "--store", str(tmp_path), "--out", str(ro / "fit")],
            "optimize": ["optimize", "--wind-grid", "7", "--out", str(ro / "opt")],
            "report": ["report", "--out", str(ro / "report.html")],
            "ingest": ["ingest", str(camp), "--store", str(ro / "store"), "--no-progress"]}
    rc = main(argv[stage])
    err = capsys.readouterr().err
    if os.geteuid() != 0:
        ro.chmod(0o755)
    assert rc == 2, err
    assert "Traceback" not in err and str(ro) in err
    assert "cannot write" in err
    assert list(ro.iterdir()) == []


# -- optimize options ----------------------------------------------------------------
@pytest.mark.parametrize(("argv", "words"), [
    (["--intervals", "100000000"], "--intervals 100000000: out of range"),
    (["--intervals", "300", "--trust"], "(--trust refines to twice as many)"),
    (["--wind-grid", "200"], "wind speed 200 m/s is outside the plausible 1 to 25 m/s"),
    (["--wind-grid", "4:30:2"], "wind speed 26 m/s is outside"),
    (["--linear-solver", "ma99"], "unknown IPOPT linear solver 'ma99'"),
    (["--solver", "fatrop", "--linear-solver", "mumps"], "only IPOPT takes a linear solver"),
])
def test_optimize_bounds_before_any_solve(tmp_path, capsys, monkeypatch, argv, words):
    """Refused at once (was: no bound; 13 minutes of failing solves for 200 m/s)."""
    import optimize.command as command

    def no_solve(*a, **kw):
        raise AssertionError("a solve started")

    monkeypatch.setattr(command, "run_optimize", no_solve)
    out = tmp_path / "opt"
    rc = main(["optimize", "--out", str(out), *argv])
    err = capsys.readouterr().err
    assert rc == 2 and words in err, err
    assert not out.exists()


def test_analyzer_time_value_of_1e9_s(store_and_campaign, capsys):
    """An analyzer record at 1e9 s is named, not silently left out of the join."""
    path = store_and_campaign[1] / "bad_01" / "analyzer.csv"
    lines = path.read_text().splitlines()
    cells = lines[-1].split(",")
    cells[1] = "1000000000.000"
    lines[-1] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n")
    _fails(store_and_campaign, capsys, f"bad_01/analyzer.csv:{len(lines)}:", "column 'Time [s]'",
           "time jumps")
