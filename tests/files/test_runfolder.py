"""The run folder on its own: one run at a time, nothing mixed, nothing left behind."""

import pytest

from warehouse_phys.files import runfolder
from warehouse_phys.files.runfolder import (
    RunFolder,
    RunFolderError,
    RunWriteError,
    lock_folder,
    make_folders,
    remove_empty,
)

FILES = ("table.npz", "summary.json")


def test_a_new_folder_is_created_locked_and_released(tmp_path):
    folder = RunFolder(tmp_path / "a" / "b", FILES)
    with folder:
        assert folder.path.is_dir()
        with pytest.raises(RunFolderError, match="is in use by another run"):
            RunFolder(folder.path, FILES, overwrite=True).open()
    RunFolder(folder.path, FILES).open().close()  # released: usable again


def test_lock_folder_is_the_run_folders_lock_and_closing_releases_it(tmp_path):
    import os

    handle = lock_folder(tmp_path)
    with pytest.raises(RunFolderError, match="is in use by another run"):
        RunFolder(tmp_path, FILES).open()
    with pytest.raises(RunFolderError, match="is in use by another run"):
        lock_folder(tmp_path)
    os.close(handle)
    with RunFolder(tmp_path, FILES), pytest.raises(RunFolderError, match="is in use"):
        lock_folder(tmp_path)
    os.close(lock_folder(tmp_path))
    (tmp_path / "table.npz").write_bytes(b"")
    for path in (tmp_path / "missing", tmp_path / "table.npz"):  # no folder, a file
        with pytest.raises(RunWriteError, match=f"cannot write {path}"):
            lock_folder(path)


def test_a_new_folder_must_not_exist(tmp_path):
    with pytest.raises(RunFolderError, match="was created by another run just now"):
        RunFolder(tmp_path, FILES, new=True).open()


def test_written_files_are_recorded_and_failures_name_the_file(tmp_path):
    with RunFolder(tmp_path / "run", FILES) as folder:
        folder.write("table.npz", lambda path: path.write_bytes(b"q"))

        def fail(path):
            raise PermissionError(13, "Permission denied")

        with pytest.raises(RunWriteError, match=r"cannot write .*summary\.json: Permission denied"):
            folder.write("summary.json", fail)
        assert folder.written == ["table.npz"]


def test_a_failed_run_removes_the_empty_folder_it_created(tmp_path):
    path = tmp_path / "run"
    with pytest.raises(KeyboardInterrupt), RunFolder(path, FILES):
        raise KeyboardInterrupt
    assert not path.exists()
    path.mkdir()
    with pytest.raises(KeyboardInterrupt), RunFolder(path, FILES):
        raise KeyboardInterrupt
    assert path.is_dir()  # not created by the run: left alone


def test_a_path_that_is_a_file_is_refused(tmp_path):
    (tmp_path / "f").write_text("x")
    with pytest.raises(RunFolderError, match="exists and is not a folder"):
        RunFolder(tmp_path / "f", FILES).open()


def test_a_name_too_long_and_a_dangling_link_are_refused_in_one_line(tmp_path):
    with pytest.raises(RunFolderError, match=r"characters\): File name too long"):
        RunFolder(tmp_path / ("x" * 300), ["a"]).open()
    link = tmp_path / "link"
    link.symlink_to(tmp_path / "nowhere" / "run")
    with pytest.raises(RunFolderError, match=r"is a link to .*nowhere/run, which does not exist"):
        RunFolder(link, ["a"], new=True).open()
    assert not (tmp_path / "nowhere").exists()


@pytest.mark.parametrize("new", [True, False])
def test_a_failed_first_run_removes_the_parents_it_made_and_no_others(tmp_path, new):
    path = tmp_path / "runs" / "day" / "run"
    with pytest.raises(KeyboardInterrupt), RunFolder(path, FILES, new=new):
        raise KeyboardInterrupt
    assert list(tmp_path.iterdir()) == []  # runs/ and runs/day/ went with the run
    other = tmp_path / "runs" / "other"
    other.mkdir(parents=True)
    with pytest.raises(KeyboardInterrupt), RunFolder(path, FILES, new=new):
        raise KeyboardInterrupt
    assert sorted(p.name for p in (tmp_path / "runs").iterdir()) == ["other"]  # not its own
    with RunFolder(path, FILES, new=new) as folder:
        folder.write("summary.json", lambda file: file.write_text("{}"))
    with pytest.raises(KeyboardInterrupt), RunFolder(tmp_path / "runs" / "day" / "b", FILES):
        raise KeyboardInterrupt
    assert sorted(p.name for p in (tmp_path / "runs" / "day").iterdir()) == ["run"]


def test_make_folders_lists_what_it_made_and_remove_empty_stops_at_a_full_one(tmp_path):
    made = make_folders(tmp_path / "a" / "b" / "c", exist_ok=False)
    assert made == [tmp_path / "a" / "b" / "c", tmp_path / "a" / "b", tmp_path / "a"]
    assert make_folders(tmp_path / "a" / "b" / "c", exist_ok=True) == []
    with pytest.raises(FileExistsError):
        make_folders(tmp_path / "a" / "b" / "c", exist_ok=False)
    (tmp_path / "a" / "b" / "kept").touch()
    remove_empty(made)
    assert sorted(p.name for p in (tmp_path / "a" / "b").iterdir()) == ["kept"]
    remove_empty(made)  # gone already, or full: nothing raises


def test_a_parent_removed_while_the_folder_is_made_is_made_again(tmp_path, monkeypatch):
    # Another run that made runs/ ends empty and removes it between our two mkdirs.
    real = runfolder.Path.mkdir
    removed = []

    def mkdir(self, *args, **kwargs):
        real(self, *args, **kwargs)
        if self.name == "runs" and not removed:
            removed.append(self)
            self.rmdir()

    monkeypatch.setattr(runfolder.Path, "mkdir", mkdir)
    with RunFolder(tmp_path / "runs" / "run", FILES, new=True) as folder:
        assert folder.path.is_dir()
    assert removed == [tmp_path / "runs"]
