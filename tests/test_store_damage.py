"""A damaged store is noticed: ingest re-ingests what is damaged and says so, never
deletes the only copy of the data, and ``bench store check`` reports without changing
anything (bench/store/damage.py, bench/store/cli.py)."""

from __future__ import annotations

import errno
import json
import os
import shutil

import pytest
from ingest_fixtures import make_points_session, make_timeseries_session
from kill_harness import damage_points_file, store_digest

from bench.ingest.pipeline import ingest
from bench.store.damage import check_store
from bench.store.manifest import read_manifest
from bench.store.read import read_points
from drivebench.cli import main
from fitting.points import load_points
from kernel.errors import InputError


@pytest.fixture
def campaign(tmp_path):
    camp = tmp_path / "camp"
    make_timeseries_session(camp, "motor_01", seed=1)
    make_points_session(camp, "table_01", seed=3)
    store = tmp_path / "store"
    ingest([camp], store, progress=False)
    return camp, store


def _edit(session):
    """Change a session's files (a comment in session.toml): it is re-ingested."""
    with open(session / "session.toml", "a") as fh:
        fh.write("\n# edited\n")


def _tree(store):
    return sorted((str(p.relative_to(store)), p.stat().st_size) for p in store.rglob("*")
                  if p.is_file() and p.name != ".lock")


@pytest.mark.parametrize("how", ["deleted", "truncated", "bit-rotted"])
def test_damaged_file_is_found_reported_and_reingested(campaign, how, capsys):
    """A deleted, truncated or bit-rotted points file: store check exits 1 naming the
    session and file and changes nothing; readers refuse with the file named; ingest of
    the same campaign re-ingests that session (status repaired) and the store equals
    the one an undamaged store gives."""
    camp, store = campaign
    healthy = store_digest(store)
    n_points = read_manifest(store)["sessions"]["motor_01"]["n_points"]
    path = damage_points_file(store, how)
    before = _tree(store)
    capsys.readouterr()
    assert main(["store", "check", "--store", str(store)]) == 1
    out = capsys.readouterr().out
    assert "motor_01" in out and "points/motor_01.parquet" in out and "DAMAGED" in out
    assert "table_01" not in out
    assert _tree(store) == before  # nothing changed
    with pytest.raises(InputError) as err:
        load_points(store)
    assert str(path.name) in str(err.value)
    lines = []
    result = ingest([camp], store, progress=False, notify=lines.append)
    assert result.ingested == ["motor_01"] and result.unchanged == ["table_01"]
    assert list(result.repaired) == ["motor_01"]
    assert any("motor_01" in line and "re-ingesting" in line for line in lines)
    assert store_digest(store) == healthy
    assert len(read_points(store).query("session_id == 'motor_01'")) == n_points
    assert main(["store", "check", "--store", str(store)]) == 0


def test_deleted_file_then_other_session_changes(campaign, tmp_path):
    """The issue's case: a listed file removed, then another session changes. The
    damaged session is re-ingested with the changed one, the point count stays whole."""
    camp, store = campaign
    n_total = len(read_points(store))
    damage_points_file(store, "deleted")
    _edit(camp / "table_01")
    result = ingest([camp], store, progress=False, notify=lambda line: None)
    assert sorted(result.ingested) == ["motor_01", "table_01"]
    assert len(read_points(store)) == n_total


def test_damaged_session_outside_the_ingest_is_refused(campaign, tmp_path):
    """Damage in a session whose folder is not ingested now: exit 2 naming the session
    and its source folder; the store (and its damage) stays as it was."""
    camp, store = campaign
    damage_points_file(store, "deleted")
    other = tmp_path / "other"
    make_timeseries_session(other, "gen_01", mode="generator", seed=2)
    before = _tree(store)
    assert main(["ingest", str(other), "--store", str(store), "--no-progress"]) == 2
    assert _tree(store) == before


def test_hand_edited_generation_never_loses_the_data(campaign, capsys):
    """The manifest's generation renamed by hand (gen-000001 -> gen-000099): store check
    says the named generation is missing and which one exists; ingest keeps gen-000001
    until a complete generation holds every session again."""
    camp, store = campaign
    healthy = store_digest(store)
    manifest_path = store / "manifest.json"
    manifest = json.loads(manifest_path.read_text())
    real = manifest["generation"]
    manifest["generation"] = "gen-000099"
    manifest_path.write_text(json.dumps(manifest))
    capsys.readouterr()
    assert main(["store", "check", "--store", str(store)]) == 1
    out = capsys.readouterr().out
    assert "gen-000099, which does not exist" in out and real in out
    assert (store / real).is_dir()
    damage = check_store(store)
    assert damage.generation and set(damage.sessions) == {"motor_01", "table_01"}
    lines = []
    result = ingest([camp], store, progress=False, notify=lines.append)
    assert sorted(result.repaired) == ["motor_01", "table_01"]
    assert store_digest(store) == healthy
    assert read_manifest(store)["generation"] == "gen-000100"
    assert not (store / real).exists()  # removed only once gen-000100 holds everything
    assert main(["store", "check", "--store", str(store)]) == 0


def test_hand_edited_generation_with_a_session_missing_keeps_the_copy(campaign, tmp_path):
    """The same edit, then an ingest of only one of the two sessions: refused (exit 2),
    gen-000001 is not removed."""
    camp, store = campaign
    manifest = json.loads((store / "manifest.json").read_text())
    real = manifest["generation"]
    manifest["generation"] = "gen-000099"
    (store / "manifest.json").write_text(json.dumps(manifest))
    part = tmp_path / "part"
    shutil.copytree(camp / "motor_01", part / "motor_01")
    assert main(["ingest", str(part), "--store", str(store), "--no-progress"]) == 2
    assert (store / real / "points" / "table_01.parquet").is_file()


def test_fsync_error_is_a_failed_commit(campaign, tmp_path, monkeypatch):
    """EIO on fsync: the ingest fails (exit 2, the reason said) and the manifest still
    names the old generation."""
    camp, store = campaign
    old = read_manifest(store)["generation"]
    _edit(camp / "table_01")

    def eio(fd):
        raise OSError(errno.EIO, "Input/output error")

    monkeypatch.setattr(os, "fsync", eio)
    assert main(["ingest", str(camp), "--store", str(store), "--no-progress"]) == 2
    monkeypatch.undo()
    assert read_manifest(store)["generation"] == old
    assert check_store(store).damaged is False


def test_manifest_is_flushed_before_the_switch(campaign, monkeypatch):
    """The new manifest.json's bytes are fsynced before os.replace puts it in place."""
    camp, store = campaign
    _edit(camp / "table_01")
    events = []
    real_fsync, real_replace = os.fsync, os.replace

    def fsync(fd):
        events.append(("fsync", os.readlink(f"/proc/self/fd/{fd}")))
        return real_fsync(fd)

    def replace(src, dst, **kw):
        events.append(("replace", str(dst)))
        return real_replace(src, dst, **kw)

    monkeypatch.setattr(os, "fsync", fsync)
    monkeypatch.setattr(os, "replace", replace)
    ingest([camp], store, progress=False)
    monkeypatch.undo()
    switch = next(i for i, e in enumerate(events)
                  if e[0] == "replace" and e[1].endswith("manifest.json"))
    assert events[switch - 1][0] == "fsync" and ".manifest.json." in events[switch - 1][1]


def test_store_check_on_no_store(tmp_path):
    assert main(["store", "check", "--store", str(tmp_path / "none")]) == 2
