"""The package as a user installs it: wheel contents, sprites outside a checkout, the CLI, lint."""

import os
import shutil
import subprocess
import sys
import tomllib
import zipfile
from pathlib import Path

import pytest

from warehouse_phys.drawing.render import SPRITE_NAMES
from warehouse_phys.world.maps import MAPS

ROOT = Path(__file__).resolve().parent.parent


@pytest.mark.slow
def test_sprites_and_maps_load_from_an_installed_wheel(tmp_path, run_python):
    source = tmp_path / "src"
    source.mkdir()
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        shutil.copy(ROOT / name, source / name)
    for folder in ("warehouse_phys", "sprites"):
        shutil.copytree(
            ROOT / folder, source / folder, ignore=shutil.ignore_patterns("__pycache__")
        )
    wheels = tmp_path / "wheels"
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
         "-w", str(wheels), str(source)],
        check=True,
    )  # fmt: skip
    (wheel,) = wheels.glob("warehouse_phys-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    for sprite in SPRITE_NAMES:
        assert f"warehouse_phys/sprites/{sprite}" in names
    for name in MAPS:  # the benchmark maps the package ships
        assert f"warehouse_phys/world/map_files/{name}.map" in names
    assert any(name.endswith(".dist-info/licenses/LICENSE") for name in names)
    # every module of the checkout ships (a subpackage left out of pyproject's list
    # installs, and fails only when a command imports it)
    package = ROOT / "warehouse_phys"
    modules = {path.relative_to(ROOT).as_posix() for path in package.rglob("*.py")}
    assert modules <= names, sorted(modules - names)

    site = tmp_path / "site"
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(site),
         str(wheel)],
        check=True,
    )  # fmt: skip
    script = (
        "import warehouse_phys.drawing.render as r, gymnasium as gym\n"
        "print(r.sprite_path('robot.png'))\n"
        "env = gym.make('warehouse-robot-v0', render_mode='rgb_array')\n"
        "env.reset(seed=0)\n"
        "print(env.render().shape)\n"
        "from warehouse_phys.world.maps import map_path\n"
        "from warehouse_phys.world.layouts import resolve_layout\n"
        "print(map_path('kiva-33-46'))\n"
        "print(resolve_layout('kiva-33-46').shelf_mask.shape)\n"
        "import warehouse_phys.simulate, warehouse_phys.evaluate\n"
        "import warehouse_phys.planners.guidance\n"
    )
    outside = tmp_path / "elsewhere"
    outside.mkdir()
    out = run_python(script, cwd=outside, env={**os.environ, "PYTHONPATH": str(site)}).splitlines()
    assert Path(out[0]).is_relative_to(site)
    assert out[1] == "(280, 320, 3)"
    assert Path(out[2]).is_relative_to(site)
    assert out[3] == "(33, 46)"


@pytest.mark.parametrize("check", [["check"], ["format", "--check"]])
def test_code_is_ruff_clean(check):
    result = subprocess.run(
        [sys.executable, "-m", "ruff", *check, "."], cwd=ROOT, capture_output=True, text=True
    )
    assert result.returncode == 0, result.stdout + result.stderr


def test_metadata_a_package_index_expects():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    assert project["license"] == "MIT"
    assert project["license-files"] == ["LICENSE"]
    assert (ROOT / "LICENSE").read_text().startswith("MIT License")
    assert project["authors"]
    assert all(author.get("name") for author in project["authors"])
    assert {"Homepage", "Repository", "Issues"} <= set(project["urls"])
    assert project["requires-python"] == ">=3.11"
    versions = {c for c in project["classifiers"] if c.startswith("Programming Language :: Python")}
    assert "Programming Language :: Python :: 3.11" in versions
    assert not any(c.startswith("License ::") for c in project["classifiers"])  # SPDX instead
    assert "sweeps/" in (ROOT / ".gitignore").read_text().splitlines()
