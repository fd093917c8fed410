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
    assert str(target) in err and "'--out'" in err
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
