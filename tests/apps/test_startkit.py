"""python -m warehouse_phys.startkit: install into a kit, refusals in one line with exit
status 2 (its runs are tested where the kit is: tests/lorr/test_startkit_runs.py)."""

import subprocess
import sys

from tests.conftest import ROOT
from warehouse_phys.apps import startkit


def test_install_writes_the_three_components(tmp_path, capsys):
    assert startkit.main(["install", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    assert printed.count("wrote ") == 3
    assert "--plannerPython true" in printed
    assert (tmp_path / "python" / "user_executor" / "pyExecutor.py").is_file()


def test_bad_command_lines_and_inputs_are_one_line_with_status_2(tmp_path, capsys):
    instance = tmp_path / "missing.json"
    cases = [
        (["install", str(tmp_path / "nowhere")], "not a folder"),
        (["run", str(instance), "--kit", str(tmp_path), "--ticks", "5", "--out", str(tmp_path)],
         "missing.json"),
        (["run", str(instance), "--ticks", "0", "--kit", "x", "--out", "y"],
         "expected a positive number of ticks"),
        (["build", "--kit", str(tmp_path)], "not a start kit"),
        (["fly"], "invalid choice: 'fly'"),
    ]  # fmt: skip
    for argv, message in cases:
        assert startkit.main(argv) == 2, argv
        error = capsys.readouterr().err
        assert message in error, error
        assert error.count("\n") == 1, error


def test_an_entry_the_environment_names_wrongly_is_one_line_with_status_2(
    tmp_path, capsys, monkeypatch
):
    from tests.lorr.tiny_kit_instance import tiny_instance
    from warehouse_phys.lorr.instances import write_instance

    path = write_instance(tiny_instance(), tmp_path / "tiny.json")
    argv = ["run", str(path), "--kit", str(tmp_path), "--ticks", "5", "--out", str(tmp_path / "o")]
    for name, value, message in (
        ("WAREHOUSE_PHYS_SCHEDULER", "hungarian", "WAREHOUSE_PHYS_SCHEDULER=hungarian: not an "),
        ("WAREHOUSE_PHYS_PLANNER", "astar", "WAREHOUSE_PHYS_PLANNER=astar: not a planner"),
    ):
        monkeypatch.setenv(name, value)
        assert startkit.main(argv) == 2
        error = capsys.readouterr().err
        assert message in error, error
        assert error.count("\n") == 1
        monkeypatch.delenv(name)
    assert startkit.main([*argv, "--scheduler", "hungarian"]) == 2
    assert "invalid choice: 'hungarian'" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_guidance_the_entry_cannot_take_is_refused_before_the_kit_runs(
    tmp_path, capsys, monkeypatch
):
    from tests.lorr.tiny_kit_instance import station_instance
    from warehouse_phys.lorr.instances import write_instance

    path = write_instance(station_instance(), tmp_path / "stations.json")
    argv = ["run", str(path), "--kit", str(tmp_path / "no-kit"), "--ticks", "5", "--out",
            str(tmp_path / "out")]  # fmt: skip
    for extra, message in (
        (["--guidance", '{"nope": 1}'], "--guidance: planner 'guided-ops-repair' has no field "
                                        "'nope'; its fields: vertex_weight"),
        (["--planner", "pibt", "--guidance", '{"reroute": 4}'],
         "--guidance: plain PIBT takes no guidance, got ['reroute']"),
        (["--guidance", '{"reroute": -1}'], "--guidance: reroute must be >= 0, got -1"),
        (["--guidance", "[]"], "argument --guidance: expected a JSON object of planner fields"),
    ):  # fmt: skip
        assert startkit.main([*argv, *extra, "--only", "simulate"]) == 2
        err = capsys.readouterr().err
        assert message in err, err
        assert err.count("\n") == 1
    monkeypatch.setenv("WAREHOUSE_PHYS_GUIDANCE", "{")
    assert startkit.main([*argv, "--only", "simulate"]) == 2
    assert "WAREHOUSE_PHYS_GUIDANCE={: not a JSON object" in capsys.readouterr().err
    monkeypatch.delenv("WAREHOUSE_PHYS_GUIDANCE")
    monkeypatch.setenv("WAREHOUSE_PHYS_ROUND_SHARE", "0")
    assert startkit.main([*argv, "--only", "simulate"]) == 2
    err = capsys.readouterr().err
    assert "WAREHOUSE_PHYS_ROUND_SHARE=0: a share above 0, or none" in err
    assert err.count("\n") == 1
    monkeypatch.delenv("WAREHOUSE_PHYS_ROUND_SHARE")
    for name in ("WAREHOUSE_PHYS_PLANNER", "WAREHOUSE_PHYS_SCHEDULER", "WAREHOUSE_PHYS_GUIDANCE",
                 "WAREHOUSE_PHYS_ROUND_SHARE"):  # fmt: skip
        monkeypatch.setenv(name, "two\nlines")  # shown quoted: still one line
        assert startkit.main([*argv, "--only", "simulate"]) == 2
        err = capsys.readouterr().err
        assert f"{name}='two\\nlines': " in err, err
        assert err.count("\n") == 1
        monkeypatch.delenv(name)
    assert not (tmp_path / "out").exists()


def test_a_folder_holding_an_earlier_run_is_refused_in_one_line_before_anything_runs(
    tmp_path, capsys
):
    from tests.lorr.test_startkit_run_folder import earlier_run
    from tests.lorr.tiny_kit_instance import tiny_instance
    from warehouse_phys.lorr.instances import write_instance

    path = write_instance(tiny_instance(), tmp_path / "tiny.json")
    out = tmp_path / "out"
    setting = {"instance": str(path), "ticks": 5, "kit": str(tmp_path), "guidance": {},
               "planner": "guided-ops-repair", "scheduler": "assignment"}  # fmt: skip
    earlier_run(out, setting=setting)
    before = {file: file.read_bytes() for file in out.rglob("*") if file.is_file()}
    argv = ["run", str(path), "--kit", str(tmp_path), "--ticks", "5", "--out", str(out)]
    for extra, message in (
        ([], "holds an earlier run (default.json, default.log, default.timings, ours.json, "),
        (["--only", "simulate"], "holds an earlier simulate run (simulate)"),
        (["--only", "ours", "--ticks", "6"], "holds a run of another setting (ticks 5, not 6)"),
    ):
        assert startkit.main([*argv, *extra]) == 2
        err = capsys.readouterr().err
        assert message in err, err
        assert "choose a new folder, or pass --overwrite to replace it" in err
        assert err.count("\n") == 1
    assert {file: file.read_bytes() for file in out.rglob("*") if file.is_file()} == before


def test_a_folder_another_command_holds_is_refused_and_one_it_made_goes_if_left_empty(
    tmp_path, capsys
):
    import os

    from tests.lorr.tiny_kit_instance import tiny_instance
    from warehouse_phys.files.runfolder import lock_folder
    from warehouse_phys.lorr.instances import write_instance

    path = write_instance(tiny_instance(), tmp_path / "tiny.json")
    held = tmp_path / "held"
    held.mkdir()
    argv = ["run", str(path), "--kit", str(tmp_path), "--ticks", "5", "--only", "ours"]
    handle = lock_folder(held)  # another command's, for as long as it runs
    try:
        assert startkit.main([*argv, "--out", str(held)]) == 2
        err = capsys.readouterr().err
        assert f"{held} is in use by another run" in err, err
        assert err.count("\n") == 1
        assert held.is_dir()
        assert not any(held.iterdir())
    finally:
        os.close(handle)
    # The lock is the command's alone while it runs: here the kit (tmp_path, not a kit)
    # cannot be built, and the folder the command made is gone with the lock.
    new = tmp_path / "new" / "out"
    assert startkit.main([*argv, "--out", str(new)]) == 2
    assert "not a start kit" in capsys.readouterr().err
    assert not (tmp_path / "new").exists()
    lock_folder(held)  # released: another command may take it now


def test_python_dash_m_runs_the_command():
    done = subprocess.run([sys.executable, "-m", "warehouse_phys.startkit", "--help"], cwd=ROOT,
                          capture_output=True, text=True)  # fmt: skip
    assert done.returncode == 0
    assert "install" in done.stdout
    assert "run" in done.stdout
