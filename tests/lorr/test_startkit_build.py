"""The kit built into a cache folder keyed by kit and interpreter, and what is missing said in
one line (no build here: the tests that need one skip without it)."""

import os

import pytest

from warehouse_phys.lorr.startkit import build


def fake_kit(folder, version="3.1.0"):
    (folder / "src").mkdir(parents=True)
    (folder / "src" / "driver.cpp").write_text("int main() {}\n")
    (folder / "CMakeLists.txt").write_text("project(lifelong)\n")
    (folder / "version.txt").write_text(f"{version}\n")
    return folder


def test_the_cache_folder_is_outside_the_checkout_and_keyed_by_kit_and_interpreter(
    tmp_path, monkeypatch
):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    one, two = fake_kit(tmp_path / "a"), fake_kit(tmp_path / "b", "3.2.0")
    folder = build.cache_folder(one)
    assert folder.parent == tmp_path / "cache" / "warehouse_phys"
    assert folder.name.startswith("startkit-3.1.0-py")
    assert build.cache_folder(one) == folder != build.cache_folder(two)
    for source in (one / "src").rglob("*"):  # copied again: new times, the same sources
        os.utime(source, (1.0, 1.0))
    assert build.cache_folder(one) == folder
    (one / "src" / "driver.cpp").write_text("int main() { return 1; }\n")  # the kit changed
    assert build.cache_folder(one) != folder
    changed = build.cache_folder(one)
    monkeypatch.setattr(build, "base_interpreter", lambda: tmp_path / "python3.99")
    assert build.cache_folder(one) != changed  # another interpreter: a build of its own


def test_missing_tools_are_named_in_one_line(tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    monkeypatch.setenv("PATH", str(tmp_path / "empty"))
    with pytest.raises(build.KitBuildError) as error:
        build.build_kit(fake_kit(tmp_path / "kit"))
    message = str(error.value)
    assert "cmake, make, a C++ compiler (g++) not found" in message
    assert "apt-get install cmake" in message
    assert "\n" not in message


def test_a_folder_that_is_not_a_kit_is_refused(tmp_path):
    with pytest.raises(build.NotAKitError, match="not a start kit"):
        build.build_kit(tmp_path)


def test_cmakes_complaint_names_the_missing_library(tmp_path):
    log = tmp_path / "build.log"
    log.write_text("CMake Error at CMakeLists.txt:22 (find_package):\n  Could NOT find Boost\n")
    assert "Boost (libboost-program-options-dev" in build._why(log, "cmake")
    log.write_text("Could not find a package configuration file provided by \"pybind11\"\n"
                   "  pybind11Config.cmake\n")  # fmt: skip
    assert "pybind11 (pybind11-dev" in build._why(log, "cmake")
    assert f"make failed (log: {log})" in build._why(log, "make")
    log.write_text("some other failure\n")
    assert build._why(log, "cmake") == f"cannot build the start kit: cmake failed (log: {log})"
