"""What the command lines share: the shipped maps by name, and warnings in one line."""

import subprocess
import sys
import warnings

import pytest

from warehouse_phys.apps import cli
from warehouse_phys.apps.train import main as train_main
from warehouse_phys.world.layouts import resolve_layout
from warehouse_phys.world.maps import MAPS

#: A map whose file holds it twice, as the 2023 examples' Paris maps do.
TWICE = "type octile\nheight 3\nwidth 4\nmap\n....\n.@..\n....\n" * 2
WARNING = "Twice.map: 7 lines after the header's 3 rows ignored (as the League of Robot Runners' "


@pytest.mark.parametrize("name", sorted(MAPS))
def test_every_command_takes_a_shipped_maps_name_as_its_layout(name):
    floor = cli.floor_from_layout(name)
    assert floor.label == name
    assert floor.grid().shelves == resolve_layout(name).shelves


def test_an_unknown_layout_names_the_presets_and_the_shipped_maps():
    with pytest.raises(cli.UsageError, match=r"a shipped map \(kiva-33-46, kiva-140-500, "):
        cli.floor_from_layout("kiva")


def test_a_command_prints_a_warning_in_one_line(tmp_path):
    # As a user sees it: a process of its own, Python's own warning filters.
    (tmp_path / "Twice.map").write_text(TWICE)
    result = subprocess.run(
        [sys.executable, "-m", "warehouse_phys.simulate", "--layout", "Twice.map", "--robots",
         "2", "--steps", "3", "--frames", "0", "--no-compare", "--quiet"],
        cwd=tmp_path, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert result.stderr == (
        f"python -m warehouse_phys.simulate: warning: {WARNING}reader ignores them)\n"
    )


@pytest.mark.filterwarnings("default::UserWarning")  # shown, as outside the tests
def test_train_prints_a_warning_in_one_line_and_puts_the_way_warnings_show_back(
    tmp_path, monkeypatch, capsys
):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "Twice.map").write_text(TWICE)
    shown = warnings.showwarning
    assert train_main(["--layout", "Twice.map", "--env", "grid", "--episodes", "20",
                       "--quiet", "--no-gif"]) == 0  # fmt: skip
    assert capsys.readouterr().err == (
        f"python -m warehouse_phys.train: warning: {WARNING}reader ignores them)\n"
    )
    assert warnings.showwarning is shown


def test_a_warning_of_several_lines_shows_its_first(capsys):
    @cli.warnings_in_one_line("prog")
    def main():
        warnings.warn("first line\nsecond line", UserWarning, stacklevel=1)
        warnings.warn("", RuntimeWarning, stacklevel=1)
        return 0

    with warnings.catch_warnings():
        warnings.simplefilter("always")
        assert main() == 0
    assert capsys.readouterr().err == ("prog: warning: first line\nprog: warning: RuntimeWarning\n")
