"""python -m warehouse_phys.simulate --physics: the bodies' measured safety in the summary,
in lock step and on ticks, on one thread or two; refusals in one line (exit 2) for counts
beyond any run and instances with out-of-range fields; a full disk names what is whole."""

import errno
import json
import os

import pytest

from tests.lorr.test_instances import write_files
from warehouse_phys.apps import train
from warehouse_phys.apps.simulate import main
from warehouse_phys.files import runfolder

SAFETY = ("closest_approach", "closest_approach_bound", "body_contacts", "wall_contacts",
          "split_contacts", "deepest_body_contact", "deepest_wall_contact", "collision_slop",
          "physics_steps_measured")  # fmt: skip
HUGE = "1" + "0" * 400


def run(tmp_path, *argv):
    out = tmp_path / "run"
    assert main([*argv, "--out", str(out), "--quiet", "--frames", "0", "--no-compare"]) == 0
    return json.loads((out / "summary.json").read_text())


@pytest.mark.parametrize("threads", ["1", "2"])
def test_a_lock_step_physics_run_reports_the_bodies_safety(tmp_path, capsys, threads):
    summary = run(tmp_path, "--physics", "--layout", "warehouse", "--robots", "40", "--steps",
                  "8", "--physics-threads", threads)  # fmt: skip
    assert summary["physics"] is True  # was a PhysicsConfig: summary.json failed to write
    assert set(SAFETY) <= set(summary)
    assert summary["body_contacts"] == summary["split_contacts"] == 0
    assert summary["closest_approach"] >= summary["closest_approach_bound"]
    assert summary["physics_steps_measured"] == 8 * 15
    assert "bodies: closest approach" in capsys.readouterr().out


def test_a_physics_run_on_ticks_reports_the_bodies_safety_on_two_threads(tmp_path, capsys):
    summary = run(tmp_path, "--physics", "--layout", "warehouse", "--robots", "60", "--steps",
                  "30", "--ticks-per-move", "3", "--p-delay", "0.02", "--moves", "rotate",
                  "--physics-threads", "2")  # fmt: skip
    assert summary["body_contacts"] == summary["wall_contacts"] == summary["split_contacts"] == 0
    assert summary["closest_approach"] >= summary["closest_approach_bound"]
    assert summary["physics_steps_measured"] == 30 * 14
    out = capsys.readouterr().out
    assert "contacts deeper than the collision slop: 0 body-body, 0 body-wall" in out


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--steps", HUGE], "argument --steps: expected a number of steps from 1 to "
                            "1,000,000,000, got an integer of 401 digits"),
        (["--steps", "1" * 5000], "got an integer of 5,000 digits"),
        (["--physics-threads", "2"], "--physics-threads steps the physics twin's bodies: "
                                     "give --physics"),
        (["--physics", "--physics-threads", "65"], "expected threads from 1 to 64, got 65"),
    ],
)  # fmt: skip
def test_counts_beyond_any_run_are_refused_in_one_line(tmp_path, capsys, argv, message):
    os.chdir(tmp_path)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert message in err
    assert not (tmp_path / "runs").exists()


def test_train_refuses_episodes_beyond_any_run_in_one_line(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert train.main(["--episodes", HUGE]) == 2
    err = capsys.readouterr().err
    assert err == ("python -m warehouse_phys.train: error: argument --episodes: expected a "
                   "positive number of episodes (at most 9,223,372,036,854,775,807), got an "
                   "integer of 401 digits\n")  # fmt: skip
    assert not (tmp_path / "runs").exists()  # nothing written


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        (f', "numTasksReveal": {HUGE}', "numTasksReveal is out of range: an integer of 401 digits"),
        (f', "agentSize": {HUGE}', "agentSize is out of range"),
        (', "x": ' + "[" * 100_000 + "]" * 100_000, "JSON nested too deeply"),
    ],
)  # fmt: skip
def test_an_instance_with_a_field_out_of_range_is_refused_in_one_line(
    tmp_path, capsys, extra, message
):
    path = write_files(tmp_path)
    path.write_text(path.read_text()[:-1] + extra + "}")
    assert main(["--instance", str(path), "--quiet", "--out", str(tmp_path / "run")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert str(path) in err
    assert message in err
    assert not (tmp_path / "run").exists()  # nothing written


def test_a_fleet_beyond_what_the_machine_holds_is_refused_naming_its_memory(
    tmp_path, capsys, monkeypatch
):
    from warehouse_phys.physics import config

    monkeypatch.setattr(config, "machine_memory", lambda: 2**20)  # 1 MiB: 64 robots
    out = tmp_path / "run"
    argv = ["--physics", "--layout", "warehouse", "--robots", "80", "--steps", "2", "--quiet"]
    assert main([*argv, "--out", str(out)]) == 2
    assert capsys.readouterr().err == (
        "python -m warehouse_phys.simulate: error: num_robots: 80 robots' bodies need about "
        "1.2 MiB (16 KiB a robot), more than this machine's 1.0 MiB: the physics world holds "
        "at most 64\n"
    )
    assert not out.exists()


def test_a_full_disk_says_which_files_are_complete(tmp_path, capsys, monkeypatch):
    write = runfolder.RunFolder.write

    def no_space(path):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    def full(self, name, writer):
        return write(self, name, no_space if name == "throughput.png" else writer)

    monkeypatch.setattr(runfolder.RunFolder, "write", full)
    out = tmp_path / "run"
    assert main(["--robots", "2", "--steps", "5", "--quiet", "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert err == (f"python -m warehouse_phys.simulate: error: cannot write {out}/throughput.png: "
                   f"No space left on device (summary.json is complete in {out})\n")  # fmt: skip
