"""kernel.files: atomic replacement and hashes shared by every stage."""

import hashlib
import os
import stat

import pytest

from kernel.files import atomic_write, file_sha256, write_text_atomic


def test_failed_write_leaves_the_old_file_and_no_temp(tmp_path):
    target = tmp_path / "out.json"
    target.write_text("old")

    def boom(tmp):
        tmp.write_text("half")
        raise RuntimeError("disk full")

    with pytest.raises(RuntimeError):
        atomic_write(target, boom)
    assert target.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out.json"]


def test_written_file_has_a_new_file_usual_mode(tmp_path):
    # Truth: the mode open() gives a new file under the current umask.
    plain = tmp_path / "plain.txt"
    plain.write_text("x")
    out = write_text_atomic(tmp_path / "sub" / "report.html", "a\nb\n")
    assert out.read_bytes() == b"a\nb\n"
    assert stat.S_IMODE(os.stat(out).st_mode) == stat.S_IMODE(os.stat(plain).st_mode)


def test_sha256_matches_hashlib_across_block_boundaries(tmp_path):
    data = os.urandom((1 << 20) + 12345)  # spans two 1 MiB read blocks
    path = tmp_path / "blob.bin"
    path.write_bytes(data)
    assert file_sha256(path) == hashlib.sha256(data).hexdigest()
