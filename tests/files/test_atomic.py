"""Atomic writes: all of the file or none of it, with ordinary permissions."""

import os
import stat

import pytest

from warehouse_phys.files.atomic import atomic_write, atomic_write_text


def test_writes_the_whole_file(tmp_path):
    path = atomic_write_text(tmp_path / "a.txt", "hello\n")
    assert path == tmp_path / "a.txt"
    assert path.read_text() == "hello\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt"]


def test_a_failed_write_keeps_the_old_file_and_leaves_no_temporary(tmp_path):
    path = tmp_path / "a.txt"
    path.write_text("old")

    def fail(file):
        file.write(b"partial")
        raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"):
        atomic_write(path, fail)
    assert path.read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.txt"]


def test_permissions_are_those_of_an_ordinary_new_file(tmp_path):
    (tmp_path / "plain.txt").write_text("x")
    atomic_write_text(tmp_path / "atomic.txt", "x")
    modes = {stat.S_IMODE(os.stat(tmp_path / name).st_mode) for name in ("plain.txt", "atomic.txt")}
    assert len(modes) == 1, modes


def test_the_umask_is_read_when_writing_not_at_import(tmp_path):
    old = os.umask(0o077)
    try:
        path = atomic_write_text(tmp_path / "private.txt", "x")
    finally:
        os.umask(old)
    assert stat.S_IMODE(os.stat(path).st_mode) == 0o600


def test_leftover_temporary_files_are_found_by_name(tmp_path):
    from warehouse_phys.files.atomic import temporary_files

    for name in (".q.npz.abc.tmp", ".q.npz.def.tmp", ".other.npz.x.tmp", "q.npz", ".q.npz"):
        (tmp_path / name).write_text("")
    assert [p.name for p in temporary_files(tmp_path, "q.npz")] == [
        ".q.npz.abc.tmp",
        ".q.npz.def.tmp",
    ]
