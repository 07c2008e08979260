"""The run folder on its own: one run at a time, nothing mixed, nothing left behind."""

import pytest

from warehouse_phys.files.runfolder import RunFolder, RunFolderError, RunWriteError

FILES = ("table.npz", "summary.json")


def test_a_new_folder_is_created_locked_and_released(tmp_path):
    folder = RunFolder(tmp_path / "a" / "b", FILES)
    with folder:
        assert folder.path.is_dir()
        with pytest.raises(RunFolderError, match="is in use by another run"):
            RunFolder(folder.path, FILES, overwrite=True).open()
    RunFolder(folder.path, FILES).open().close()  # released: usable again


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
