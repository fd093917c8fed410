"""Bad input (issue 2 section 4): a clear error naming file, line or column and what was
expected; exit code 2 from the CLI; and a store left byte for byte as it was."""

from __future__ import annotations

import numpy as np
import pytest
from ingest_fixtures import make_points_session, make_timeseries_session, store_tree

from bench.ingest.scrub import MAX_NAN_RUN
from drivebench.cli import main


def _fails(store_and_campaign, capsys, *fragments, extra=()):
    """Ingest good + bad campaign; assert exit 2, message fragments, untouched store."""
    good, camp, store = store_and_campaign
    before = store_tree(store)
    rc = main(["ingest", str(good), str(camp), "--store", str(store), "--no-progress", *extra])
    err = capsys.readouterr().err
    assert rc == 2, err
    for f in fragments:
        assert f in err, (f, err)
    assert store_tree(store) == before
    return err


def _edit_lines(path, fn):
    lines = path.read_text().splitlines()
    path.write_text("\n".join(fn(lines)) + "\n")


def test_missing_column(store_and_campaign, capsys):
    daq = store_and_campaign[1] / "bad_01" / "daq.csv"
    _edit_lines(daq, lambda ls: [",".join(l.split(",")[:2]) for l in ls])
    _fails(store_and_campaign, capsys, "daq.csv:1", "column 'torque'", "missing column for torque",
           "expected a column named like 'Torque'")


def test_unknown_unit(store_and_campaign, capsys):
    daq = store_and_campaign[1] / "bad_01" / "daq.csv"
    _edit_lines(daq, lambda ls: [ls[0].replace("[1/min]", "[rps]")] + ls[1:])
    _fails(store_and_campaign, capsys, "daq.csv:1", "column 'Speed [rps]'", "unknown unit 'rps'",
           "expected rpm, 1/min")


@pytest.mark.parametrize("what", ["backwards", "repeats"])
def test_time_not_increasing(store_and_campaign, capsys, what):
    daq = store_and_campaign[1] / "bad_01" / "daq.csv"

    def edit(ls):
        row = ls[500].split(",")
        row[0] = ls[498].split(",")[0] if what == "backwards" else ls[499].split(",")[0]
        ls[500] = ",".join(row)
        return ls

    _edit_lines(daq, edit)
    # line 501 of the file is data row index 499 (one header line)
    _fails(store_and_campaign, capsys, "daq.csv:501", "column 'Time [s]'", what,
           "expected strictly increasing time")


def test_run_of_nan(store_and_campaign, capsys):
    daq = store_and_campaign[1] / "bad_01" / "daq.csv"
    n = MAX_NAN_RUN + 5

    def edit(ls):
        for k in range(2000, 2000 + n):
            t, s, _ = ls[k].split(",")
            ls[k] = f"{t},{s},NAN"
        return ls

    _edit_lines(daq, edit)
    _fails(store_and_campaign, capsys, "daq.csv:2001", "column 'Torque [N m]'",
           f"run of {n} consecutive invalid values", f"at most {MAX_NAN_RUN}")


def test_isolated_markers_are_fine(store_and_campaign, capsys):
    daq = store_and_campaign[1] / "bad_01" / "daq.csv"

    def edit(ls):
        for k in range(100, 3000, 97):  # every 97th row, never two in a row
            t, s, _ = ls[k].split(",")
            ls[k] = f"{t},{s},{'9.9E37' if k % 2 else 'INF'}"
        return ls

    _edit_lines(daq, edit)
    good, camp, store = store_and_campaign
    assert main(["ingest", str(camp), "--store", str(store), "--no-progress"]) == 0


def test_truncated_file(store_and_campaign, capsys):
    daq = store_and_campaign[1] / "bad_01" / "daq.csv"
    text = daq.read_text()
    cut = text.rstrip("\n").rfind(",")  # last line cut inside its last field separator
    daq.write_text(text[:cut])
    n_lines = text.count("\n")
    _fails(store_and_campaign, capsys, f"daq.csv:{n_lines}", "row has 2 fields (truncated row?)",
           "expected 3 fields separated by ','")


def test_flipped_torque_sign(store_and_campaign, capsys):
    good, camp, store = store_and_campaign
    import shutil

    shutil.rmtree(camp / "bad_01")
    make_timeseries_session(camp, "bad_01", torque_sign_logged=-1)
    _fails(store_and_campaign, capsys, "session.toml", "column 'torque_sign'",
           "torque sign convention looks flipped", "expected torque_sign = -1")


def test_empty_file(store_and_campaign, capsys):
    (store_and_campaign[1] / "bad_01" / "analyzer.csv").write_bytes(b"")
    _fails(store_and_campaign, capsys, "analyzer.csv", "file is empty")


def test_binary_file_named_csv(store_and_campaign, capsys):
    rng = np.random.default_rng(0)
    (store_and_campaign[1] / "bad_01" / "daq.csv").write_bytes(b"TDSm" + rng.bytes(5000))
    _fails(store_and_campaign, capsys, "daq.csv:1", "binary file, not a delimited text file")


def test_mapping_names_missing_column(store_and_campaign, capsys):
    good, camp, store = store_and_campaign
    make_points_session(camp, "table_01")
    mp = camp / "table_01" / "mapping.toml"
    mp.write_text(mp.read_text().replace('"M_mean"', '"M_mittel"'))
    _fails(store_and_campaign, capsys, "mapping.toml", "column 'M_mittel'",
           "mapping names column 'M_mittel' for torque, but points.csv has no such column",
           "expected one of the file's columns: 'n_mean', 'M_mean'")


def test_failed_first_ingest_creates_no_store(tmp_path, capsys):
    make_timeseries_session(tmp_path / "camp", "bad_01")
    (tmp_path / "camp" / "bad_01" / "daq.csv").write_text("")
    store = tmp_path / "new_store"
    assert main(["ingest", str(tmp_path / "camp"), "--store", str(store), "--no-progress"]) == 2
    assert not store.exists()


def test_analyzer_of_another_run(store_and_campaign, capsys):
    good, camp, store = store_and_campaign
    import shutil

    other = camp.parent / "other"
    # a run that held one setpoint: its power has no steps to match the DAQ's
    make_timeseries_session(other, "x", setpoints=[(900.0, 40.0)] * 6, seed=3)
    shutil.copy(other / "x" / "analyzer.csv", camp / "bad_01" / "analyzer.csv")
    _fails(store_and_campaign, capsys, "bad_01/analyzer.csv",
           "analyzer power does not follow the DAQ",
           "expected the power-analyzer record of the same bench run as daq.csv")


@pytest.mark.parametrize(("keep", "problem"), [
    (0.5, "differ in length"), (100, "TDMS file holds no groups (truncated file?)")])
def test_truncated_tdms(tmp_path, capsys, keep, problem):
    good = tmp_path / "good"
    make_timeseries_session(good, "good_01", markers=False)
    camp = tmp_path / "camp"
    make_timeseries_session(camp, "bad_01", daq_format="tdms")
    p = camp / "bad_01" / "daq.tdms"
    data = p.read_bytes()
    p.write_bytes(data[: int(len(data) * keep) if keep < 1 else keep])
    store = tmp_path / "store"
    assert main(["ingest", str(good), "--store", str(store), "--no-progress"]) == 0
    _fails((good, camp, store), capsys, "daq.tdms", problem)
