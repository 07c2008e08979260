"""The kit's three Python files: written for this interpreter, loading the package from the
installing environment, refusing another Python in one line, keeping a participant's own."""

import subprocess
import sys

import pytest

from warehouse_phys.lorr.startkit.install import COMPONENTS, MARK, InstallError, install


def test_the_three_files_load_the_adapters_under_the_kits_class_names(tmp_path):
    written = install(tmp_path)
    assert [p.relative_to(tmp_path).as_posix() for p in written] == [
        f"python/{folder}/{name}.py" for folder, name, _, _ in COMPONENTS
    ]
    for folder, name, adapter, _ in COMPONENTS:
        # As the kit imports it: its folder first on the path, from a bare interpreter.
        script = (f"import sys; sys.path.insert(0, 'python/{folder}'); import {name}; "
                  f"from warehouse_phys.lorr.startkit import adapters; "
                  f"assert issubclass({name}.{name}, adapters.{adapter}); print('ok')")  # fmt: skip
        done = subprocess.run([sys.executable, "-S", "-c", script], cwd=tmp_path,
                              capture_output=True, text=True)  # fmt: skip
        assert done.stdout.strip() == "ok", done.stderr


def test_another_python_is_refused_in_one_line(tmp_path):
    install(tmp_path)
    path = tmp_path / "python" / "user_planner" / "pyMAPFPlanner.py"
    text = path.read_text()
    version = f"({sys.version_info[0]}, {sys.version_info[1]})"
    path.write_text(text.replace(f"_PYTHON = {version}", "_PYTHON = (2, 7)"))
    done = subprocess.run([sys.executable, "-c", "import sys; sys.path.insert(0, "
                           "'python/user_planner'); import pyMAPFPlanner"], cwd=tmp_path,
                          capture_output=True, text=True)  # fmt: skip
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("ImportError: warehouse_phys was installed for Python ")
    assert (
        f"this kit runs Python {sys.version_info[0]}.{sys.version_info[1]}: build the kit" in last
    )


def test_a_participants_own_component_is_kept_unless_forced(tmp_path):
    own = tmp_path / "python" / "user_executor" / "pyExecutor.py"
    own.parent.mkdir(parents=True)
    own.write_text("class pyExecutor: pass\n")
    with pytest.raises(InstallError, match="not written by warehouse_phys"):
        install(tmp_path)
    assert own.read_text() == "class pyExecutor: pass\n"
    install(tmp_path, force=True)
    assert MARK in own.read_text()
    install(tmp_path)  # ours now: rewritten without --force


def test_a_folder_that_is_not_one_is_refused(tmp_path):
    with pytest.raises(InstallError, match="not a folder"):
        install(tmp_path / "nowhere")
    (tmp_path / "CMakeLists.txt").write_text("project(lifelong)\n")
    with pytest.raises(InstallError, match="without a python/ folder"):
        install(tmp_path)
