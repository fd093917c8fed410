"""Every stage verifies what it reads against the recorded sizes and SHA-256 (the store
manifest, an output folder's run.json) before using it: a substituted, bit-flipped or
deleted input stops with exit 2 naming the file and the command that repairs it
(bench/files.py recorded_mismatch, the one check behind them all)."""

from __future__ import annotations

import shutil

import pytest
from energy_fixtures import model_with_covariance, write_optimize_folder
from ingest_fixtures import make_timeseries_session

from bench.store.manifest import read_manifest
from drivebench.cli import main
from fitting.model_file import save_power_model
from kernel.files import recorded_mismatch
from kernel.output_folder import output_folder
from optimize.paper_model import paper_model

SITE = ["--weibull-k", "2", "--mean-speed", "6"]


def _flip(path):
    data = bytearray(path.read_bytes())
    data[len(data) // 3] ^= 0x10
    path.write_bytes(bytes(data))


def _substitute_generation(store, tmp_path):
    """Replace the store's generation folder with another campaign's of the same session."""
    other = tmp_path / "other"
    make_timeseries_session(other, "good_01", seed=11, markers=False)
    other_store = tmp_path / "other_store"
    assert main(["ingest", str(other), "--store", str(other_store), "--no-progress"]) == 0
    gen = store / read_manifest(store)["generation"]
    shutil.rmtree(gen)
    shutil.copytree(other_store / read_manifest(other_store)["generation"], gen)
    return gen / "points" / "good_01.parquet"


def _damage_store(store, tmp_path, how):
    path = store / read_manifest(store)["generation"] / "points" / "good_01.parquet"
    if how == "substituted":
        return _substitute_generation(store, tmp_path)
    if how == "deleted":
        path.unlink()
    else:
        _flip(path)
    return path


def test_recorded_mismatch_against_a_hand_computed_record(tmp_path):
    """Missing, resized and altered files against a record computed here with hashlib."""
    import hashlib

    path = tmp_path / "f.bin"
    path.write_bytes(b"abc")
    rec = {"bytes": 3, "sha256": hashlib.sha256(b"abc").hexdigest()}
    assert recorded_mismatch(path, rec) is None
    assert recorded_mismatch(path, rec, data=b"abc") is None
    assert recorded_mismatch(path, rec, data=b"abd").startswith("content differs")
    assert recorded_mismatch(path, {**rec, "bytes": 4}) == "3 bytes, 4 recorded"
    assert recorded_mismatch(tmp_path / "gone", rec) == "missing"


@pytest.mark.parametrize("how", ["substituted", "bit-flipped", "deleted"])
def test_fit_refuses_a_damaged_store(store_and_campaign, tmp_path, how, capsys):
    _, _, store = store_and_campaign
    path = _damage_store(store, tmp_path, how)
    capsys.readouterr()
    code = main(["fit", "--store", str(store), "--out", str(tmp_path / "fit")])
    err = capsys.readouterr().err
    assert code == 2, err
    assert path.name in err and "bench store check" in err and "bench ingest" in err
    assert not (tmp_path / "fit").exists()


@pytest.mark.parametrize("how", ["substituted", "bit-flipped", "deleted"])
def test_report_refuses_a_damaged_store(store_and_campaign, tmp_path, how, capsys):
    _, _, store = store_and_campaign
    path = _damage_store(store, tmp_path, how)
    capsys.readouterr()
    out = tmp_path / "report.html"
    code = main(["report", "--store", str(store), "--fit", str(tmp_path / "no_fit"),
                 "--optimize", str(tmp_path / "no_opt"), "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 2, err
    assert path.name in err and "bench store check" in err
    assert not out.exists()


def _optimize_out(tmp_path, name="opt"):
    """A synthetic optimize folder written whole by the sweep's writer, with its run.json."""
    return write_optimize_folder(tmp_path / name, model_with_covariance())


def _damage_folder(folder, tmp_path, how, name):
    path = folder / name
    if how == "substituted":  # the same file of another run
        other = write_optimize_folder(tmp_path / "another", paper_model(), failed=("elec-lim-7.0",))
        shutil.copy(other / name, path)
    elif how == "deleted":
        path.unlink()
    else:
        _flip(path)
    return path


@pytest.mark.parametrize("how", ["substituted", "bit-flipped", "deleted"])
def test_aep_refuses_a_damaged_optimize_folder(tmp_path, how, capsys):
    folder = _optimize_out(tmp_path)
    path = _damage_folder(folder, tmp_path, how, "summary.parquet")
    code = main(["aep", "--optimize", str(folder), "--out", str(tmp_path / "aep"), *SITE])
    err = capsys.readouterr().err
    assert code == 2, err
    assert str(path) in err and "run.json" in err and "run bench optimize again" in err
    assert not (tmp_path / "aep").exists()


@pytest.mark.parametrize("stage", ["aep", "report"])
def test_a_folder_whose_run_record_was_deleted_is_refused(tmp_path, stage, capsys):
    """Deleting run.json does not make a folder pass for one written before run ids: its
    manifest names the run."""
    folder = _optimize_out(tmp_path)
    (folder / "run.json").unlink()
    args = (["aep", "--optimize", str(folder), "--out", str(tmp_path / "aep"), *SITE]
            if stage == "aep" else
            ["report", "--optimize", str(folder), "--out", str(tmp_path / "r.html")])
    code = main(args)
    err = capsys.readouterr().err
    assert code == 2, err
    assert str(folder / "run.json") in err and "manifest.json records run" in err


def _fit_out(tmp_path):
    with output_folder(tmp_path / "fit", "fit") as stage:
        save_power_model(paper_model(), stage / "power_model.json")
        (stage / "loss_table.csv").write_text("speed_rpm,torque_nm,loss_w\n0,0,0\n")
    return tmp_path / "fit" / "power_model.json"


@pytest.mark.parametrize("how", ["substituted", "bit-flipped", "deleted"])
def test_size_refuses_a_damaged_fit_folder(tmp_path, how, capsys):
    path = _fit_out(tmp_path)
    if how == "substituted":  # another model in its place
        save_power_model(model_with_covariance(), path)
    elif how == "deleted":  # another file of the run deleted: the folder is not whole
        path = path.parent / "loss_table.csv"
        path.unlink()
    else:
        _flip(path)
    code = main(["size", "--drive-model", str(path.parent / "power_model.json"),
                 "--out", str(tmp_path / "size"), "--scales", "1", "--wind-grid", "6,8", *SITE])
    err = capsys.readouterr().err
    assert code == 2, err
    assert str(path) in err and "run bench fit again" in err
    assert not (tmp_path / "size").exists()
