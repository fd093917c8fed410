"""One --out rule for every stage: a new folder or file, or an earlier output of the same
stage; nothing else is overwritten (bench/output_folder.py)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from drivebench.cli import main
from kernel.errors import InputError
from kernel.locking import output_lock
from kernel.output_folder import check_output_folder, check_replaceable, output_folder


@pytest.mark.parametrize("victim", ["store/manifest.json", "notes.html", "fit_out"])
def test_report_out_refuses_what_is_not_an_earlier_report(tmp_path, victim, capsys):
    """--out onto a store manifest, another HTML file or a folder: exit 2, left unchanged."""
    target = tmp_path / victim
    target.parent.mkdir(parents=True, exist_ok=True)
    if victim == "fit_out":
        target.mkdir()
    else:
        target.write_text('{"schema": "drivebench.store"}' if victim.endswith(".json")
                          else "<!DOCTYPE html><html><h1>my notes</h1></html>")
    before = None if target.is_dir() else target.read_bytes()
    argv = ["report", "--store", str(tmp_path / "no_store"), "--fit", str(tmp_path / "no_fit"),
            "--optimize", str(tmp_path / "no_opt"), "--out", str(target)]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert str(target) in err and "option --out" in err
    assert before is None or target.read_bytes() == before


def test_report_out_replaces_an_earlier_report(tmp_path, capsys):
    out = tmp_path / "report.html"
    argv = ["report", "--store", str(tmp_path / "no_store"), "--fit", str(tmp_path / "no_fit"),
            "--optimize", str(tmp_path / "no_opt"), "--out", str(out)]
    assert main(argv) == 0
    first = out.read_bytes()
    assert b'<meta name="generator" content="drivebench report">' in first
    assert main(argv) == 0


def _write_other_run(target, stage):
    """Another process writes ``target`` whole as ``stage`` (as a concurrent run would)."""
    code = ("import sys; from kernel.output_folder import output_folder\n"
            "with output_folder(sys.argv[1], sys.argv[2]) as d:\n"
            "    (d / 'other.txt').write_text('other run')\n")
    subprocess.run([sys.executable, "-c", code, str(target), stage], check=True,
                   cwd=Path(__file__).resolve().parents[1])


def test_a_run_that_another_wrote_over_meanwhile_stops(tmp_path):
    """Two runs of one stage into one folder: the one that finishes second stops (exit 2
    message naming the folder), the first's output stays whole."""
    target = tmp_path / "fit"
    check_replaceable(target, "fit")  # this run starts
    _write_other_run(target, "fit")  # another run writes the folder meanwhile
    other = check_output_folder(target)
    with pytest.raises(InputError, match="another bench fit .* wrote it while this one ran"):
        with output_folder(target, "fit") as stage:
            (stage / "mine.txt").write_text("this run")
    assert check_output_folder(target) == other and not (target / "mine.txt").exists()
    check_replaceable(target, "fit")  # a run started after it replaces it
    with output_folder(target, "fit") as stage:
        (stage / "mine.txt").write_text("this run")
    assert (target / "mine.txt").exists()


def test_a_writer_waits_for_or_stops_at_another(tmp_path):
    target = tmp_path / "fit"
    code = ("import sys; from kernel.locking import output_lock\n"
            "with output_lock(sys.argv[1], 'fit', wait=False): pass\n")
    with output_lock(target, "fit"):
        busy = subprocess.run([sys.executable, "-c", code, str(target)], capture_output=True,
                              text=True, cwd=Path(__file__).resolve().parents[1])
    assert busy.returncode != 0 and "is writing it" in busy.stderr
    assert f"pid {os.getpid()}" in busy.stderr
    free = subprocess.run([sys.executable, "-c", code, str(target)],
                          cwd=Path(__file__).resolve().parents[1])
    assert free.returncode == 0


# -- no output inside another stage's output folder or a store (issue 41) ---------------

@pytest.fixture(scope="module")
def sweep(tmp_path_factory):
    """A whole optimize folder (the cycle fixtures' analytic sweep)."""
    from tests.cycle_fixtures import write_cycle_sweep

    folder = tmp_path_factory.mktemp("rule") / "opt"
    write_cycle_sweep(folder)
    return folder


def _tree(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*"))
            if p.is_file()}


@pytest.mark.parametrize("argv, inside", [
    (lambda s, t: ["aep", "--optimize", str(s), "--weibull-k", "2", "--mean-speed", "6",
                   "--out", str(s / "aep")], "aep"),
    (lambda s, t: ["cycle", "verify", "--store", str(t / "store"), "--optimize", str(s),
                   "--out", str(s / "verify")], "verify"),
    (lambda s, t: ["cycle", "export", "--optimize", str(s), "--scenario", "elec-lim-7.0",
                   "--out", str(s / "profile.csv")], "profile.csv"),
    (lambda s, t: ["report", "--store", str(t / "no_store"), "--fit", str(t / "no_fit"),
                   "--optimize", str(s), "--out", str(s / "report.html")], "report.html"),
    (lambda s, t: ["fit", "--store", str(t / "no_store"), "--out", str(s / "fit" / "deep")],
     "fit/deep"),
    (lambda s, t: ["ingest", str(t / "camp"), "--store", str(s / "store")], "store"),
], ids=["aep", "cycle verify", "cycle export", "report", "fit", "ingest"])
def test_no_output_lands_inside_another_stages_folder(sweep, tmp_path, capsys, argv, inside):
    """Each stage's --out (--store) inside an optimize folder: exit 2 naming the option and
    the folder, nothing created there (no lock file, no staging, no parent folder), the
    folder still whole for every later reader."""
    before = _tree(sweep)
    (tmp_path / "camp").mkdir()
    assert main(argv(sweep, tmp_path)) == 2
    err = capsys.readouterr().err
    assert f"lies inside {sweep}, a bench optimize output (run.json)" in err, err
    assert ("option --store" if inside == "store" else "option --out") in err
    assert "Traceback" not in err
    assert _tree(sweep) == before and sorted(p.name for p in sweep.iterdir()) == sorted(
        p.split("/")[0] for p in before)
    assert check_output_folder(sweep)


def test_no_output_lands_inside_a_store(tmp_path, capsys):
    store = tmp_path / "store"
    store.mkdir()
    (store / "manifest.json").write_text(
        '{"schema": "drivebench.store", "schema_version": 3, "sessions": {}}')
    argv = ["report", "--store", str(store), "--fit", str(tmp_path / "f"), "--optimize",
            str(tmp_path / "o"), "--out", str(store / "report.html")]
    assert main(argv) == 2
    assert "a drivebench store (manifest.json)" in capsys.readouterr().err
    assert sorted(p.name for p in store.iterdir()) == ["manifest.json"]


def test_a_refused_report_leaves_no_lock_file(tmp_path, capsys):
    """--out onto a user's own HTML file: refused under the lock, and the lock file is
    gone with it; a report that succeeds leaves none either."""
    mine = tmp_path / "notes.html"
    mine.write_text("<!DOCTYPE html><p>mine</p>")
    argv = ["report", "--store", str(tmp_path / "s"), "--fit", str(tmp_path / "f"),
            "--optimize", str(tmp_path / "o")]
    assert main([*argv, "--out", str(mine)]) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.html"]
    assert main([*argv, "--out", str(tmp_path / "sub" / "r.html")]) == 0
    assert sorted(p.name for p in (tmp_path / "sub").iterdir()) == ["r.html"]
    capsys.readouterr()


def test_the_lock_file_is_removed_only_by_its_holder(tmp_path):
    """A second writer waiting on the lock file its holder removes locks the new one: two
    writers never hold the lock at once."""
    target = tmp_path / "out"
    code = ("import sys, time; from kernel.locking import output_lock\n"
            "with output_lock(sys.argv[1], 'fit'):\n"
            "    open(sys.argv[2], 'a').write('in\\n'); time.sleep(0.3)\n"
            "    open(sys.argv[2], 'a').write('out\\n')\n")
    log = tmp_path / "log.txt"
    cwd = Path(__file__).resolve().parents[1]
    procs = [subprocess.Popen([sys.executable, "-c", code, str(target), str(log)], cwd=cwd)
             for _ in range(3)]
    assert all(p.wait() == 0 for p in procs)
    assert log.read_text().split() == ["in", "out"] * 3
    assert not (tmp_path / ".out.lock").exists()
