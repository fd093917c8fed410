"""Every stage output folder is written whole and switched in one step; readers refuse a
mixed one (kernel/output_folder.py). tests/fitting/test_fit_atomic.py kills bench fit;
benchmarks/output_kill.py runs the kill check at scale."""

from __future__ import annotations

import errno
import json
import os

import pytest

from kernel.errors import InputError
from kernel.output_folder import RUN_FILE, check_output_folder, output_folder


def test_folder_is_switched_whole(tmp_path):
    """A new output replaces the old one whole (a stale file of the old run is gone),
    run.json lists every file with its hash, and the check passes."""
    out = tmp_path / "out"
    with output_folder(out, "demo") as stage:
        (stage / "a.txt").write_text("old")
        (stage / "stale.txt").write_text("x")
    first = check_output_folder(out)
    with output_folder(out, "demo") as stage:
        (stage / "a.txt").write_text("new")
        (stage / "sub").mkdir()
        (stage / "sub" / "b.txt").write_text("b")
    second = check_output_folder(out)
    assert first and second and first != second
    assert sorted(p.name for p in out.rglob("*")) == ["a.txt", "b.txt", RUN_FILE, "sub"]
    run = json.loads((out / RUN_FILE).read_text())
    assert set(run["files"]) == {"a.txt", "sub/b.txt"} and run["stage"] == "demo"
    # no staging left, nor the writer's lock file (kernel.locking removes it)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_failure_keeps_the_old_folder(tmp_path):
    out = tmp_path / "out"
    with output_folder(out, "demo") as stage:
        (stage / "a.txt").write_text("old")
    with pytest.raises(RuntimeError), output_folder(out, "demo") as stage:
        (stage / "a.txt").write_text("half")
        raise RuntimeError("late failure")
    assert (out / "a.txt").read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]


def test_fsync_error_keeps_the_old_folder(tmp_path, monkeypatch):
    out = tmp_path / "out"
    with output_folder(out, "demo") as stage:
        (stage / "a.txt").write_text("old")

    def eio(fd):
        raise OSError(errno.EIO, "Input/output error")

    monkeypatch.setattr(os, "fsync", eio)
    with pytest.raises(InputError, match="cannot flush"), output_folder(out, "demo") as stage:
        (stage / "a.txt").write_text("new")
    monkeypatch.undo()
    assert (out / "a.txt").read_text() == "old"


def test_foreign_folder_is_not_replaced(tmp_path):
    """A folder holding files no earlier run of the stage wrote is refused, untouched."""
    out = tmp_path / "project"
    out.mkdir()
    (out / "thesis.tex").write_text("keep me")
    with pytest.raises(InputError, match="not an earlier bench demo output"):
        with output_folder(out, "demo"):
            pass
    assert (out / "thesis.tex").read_text() == "keep me"


@pytest.mark.parametrize("change", ["edited", "removed", "added"])
def test_mixed_folder_is_refused(tmp_path, change):
    out = tmp_path / "out"
    with output_folder(out, "demo") as stage:
        (stage / "a.txt").write_text("a")
        (stage / "b.txt").write_text("b")
    if change == "edited":
        (out / "a.txt").write_text("from another run")
    elif change == "removed":
        (out / "b.txt").unlink()
    else:
        (out / "c.tmp").write_text("leftover")
    with pytest.raises(InputError, match="mixed|missing"):
        check_output_folder(out)
