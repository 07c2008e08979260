"""``python -m warehouse_phys.sweep`` on a real local Ray: results, resuming, failures."""

import csv
import json
import os
import subprocess
import sys
import time
from unittest import mock

import gymnasium as gym
import numpy as np
import pytest

from warehouse_phys import sweep as sweep_cli
from warehouse_phys.apps.runs import RUN_FILES
from warehouse_phys.apps.sweep import on_ray as sweep_ray
from warehouse_phys.apps.sweep import trials as sweep_trials
from warehouse_phys.rl.greedy_policy import evaluate
from warehouse_phys.rl.qlearning import load_q_table

SWEEP = ["--env", "grid", "phys", "--seeds", "2", "--episodes", "60"]
BLOCKED = "runs/phys-default-a0.9-g0.9-e60-seed1"


def run_sweep(*args, cwd, env=None):
    return subprocess.run(
        [sys.executable, "-m", "warehouse_phys.apps.sweep", *args],
        cwd=cwd, capture_output=True, text=True, timeout=300, env=env,
    )  # fmt: skip


def read_rows(folder):
    with (folder / "results.csv").open() as file:
        return list(csv.DictReader(file))


@pytest.mark.slow
def test_a_sweep_on_ray_records_every_trial_resumes_and_reports_failures(
    tmp_path, monkeypatch, capfd
):
    import ray

    out = tmp_path / "sweep"
    (out / "runs").mkdir(parents=True)
    (out / BLOCKED).write_text("in the way")  # this trial's folder cannot be written
    monkeypatch.chdir(tmp_path)
    argv = [*SWEEP, "--out", str(out)]
    # Both sweeps run here, on one real local Ray: the one a sweep without --address
    # starts (ray_session, as main's), which each sweep finds running and uses. A local
    # Ray costs some 9 s of CPU to start (its agents and monitors are Python processes),
    # and a sweep's own process as much again to import Ray Tune: the command in a fresh
    # process, and a Ray it starts and ends itself, are the killed-driver test's
    # (test_sweep_resume). capfd reads the file descriptors, as a subprocess's pipes did.
    with mock.patch.dict(os.environ), sweep_ray.ray_session(None, 1, prestart_workers=False):
        capfd.readouterr()
        status = sweep_cli.main(argv)
        first = capfd.readouterr()
        assert status == 1, first.err
        assert "Traceback" not in first.err
        assert first.err.strip().endswith(f"1 of 4 trials failed; see {out / 'results.csv'}")
        assert first.out.startswith(f"4 trials in {out}: 0 already finished, 4 to run\n")
        rows = read_rows(out)
        assert [row["trial"] for row in rows] == [
            f"{env}-default-a0.9-g0.9-e60-seed{seed}" for env in ("grid", "phys") for seed in (0, 1)
        ]
        failed = [row for row in rows if row["status"] == "failed"]
        assert [row["folder"] for row in failed] == [BLOCKED]
        assert "exists and is not a folder" in failed[0]["error"]
        assert json.loads((out / "results.json").read_text())["trials"][3]["status"] == "failed"
        assert (out / "summary.png").read_bytes()[:4] == b"\x89PNG"

        # Every finished row is its folder: the table loads and evaluates as recorded.
        started = {}
        for row in rows:
            if row["status"] != "done":
                continue
            folder = out / row["folder"]
            assert sorted(p.name for p in folder.iterdir()) == sorted(
                set(RUN_FILES) - {"episode.gif"}
            )
            q, metadata = load_q_table(folder / "qtable.npz")
            assert metadata["seed"] == int(row["seed"])
            assert metadata["episodes"] == int(row["episodes"]) == int(row["training_episodes"])
            env_id = "warehouse-robot-v0" if row["env"] == "grid" else "warehouse-robot-phys-v0"
            assert metadata["env_id"] == env_id
            evaluation = evaluate(gym.make(f"warehouse_phys:{env_id}"), q)
            assert evaluation.optimal == int(row["optimal"])
            assert evaluation.optimal / len(evaluation.results) == pytest.approx(
                float(row["fraction_optimal"])
            )
            started[row["trial"]] = json.loads((folder / "summary.json").read_text())["started"]
            started[row["trial"] + "/mtime"] = (folder / "qtable.npz").stat().st_mtime_ns

        # Ray's workers run trial after trial (reuse_actors): each table is still the one
        # its trial makes on its own, here in this process.
        alone = tmp_path / "alone"
        trials = sweep_trials.trials_from_args(sweep_cli.build_parser().parse_args(SWEEP))
        for trial in trials:
            if trial.folder != BLOCKED:
                sweep_ray.run_trial(trial.to_job(alone, gif=False))
                np.testing.assert_array_equal(
                    load_q_table(alone / trial.folder / "qtable.npz")[0],
                    load_q_table(out / trial.folder / "qtable.npz")[0],
                )

        # The same command again, the obstacle gone: only the failed trial trains.
        (out / BLOCKED).unlink()
        capfd.readouterr()
        status = sweep_cli.main(argv)
        second = capfd.readouterr()
        assert status == 0, second.err
    assert not ray.is_initialized()  # the Ray the block started is shut down
    assert second.out.startswith(f"4 trials in {out}: 3 already finished, 1 to run\n")
    assert "[1/1] phys-default-a0.9-g0.9-e60-seed1: done" in second.out
    rows = read_rows(out)
    assert [row["status"] for row in rows] == ["done"] * 4
    for row in rows[:3]:
        folder = out / row["folder"]
        assert json.loads((folder / "summary.json").read_text())["started"] == started[row["trial"]]
        assert (folder / "qtable.npz").stat().st_mtime_ns == started[row["trial"] + "/mtime"]


def test_without_ray_the_sweep_exits_2_with_the_install_line(monkeypatch, capsys):
    import importlib.util

    real_find_spec = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util,
        "find_spec",
        lambda name, *a: None if name.split(".")[0] == "ray" else real_find_spec(name, *a),
    )
    assert sweep_cli.main(["--seeds", "1"]) == 2
    err = capsys.readouterr().err
    assert err == (
        "python -m warehouse_phys.sweep: error: the sweep runs on Ray Tune, which is not "
        'installed: pip install "warehouse_phys[ray]"\n'
    )


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--seeds", "0"], "argument --seeds: expected a count N >= 1 or a range A-B, got '0'"),
        (["--seeds", "5-2"], "expected a count N >= 1 or a range A-B, got '5-2'"),
        (["--alpha", "2"], r"alpha must be in \(0, 1\], got 2.0"),
        (["--env", "mujoco"], "argument --env: invalid choice: 'mujoco'"),
        (["--layout", "office"], "--layout 'office' is neither a preset"),
        (["--rows", "300", "--cols", "300"], "a 300x300 floor needs a Q-table of 241.4 GiB"),
        (["--seeds", "0-" + "9" * 30], "argument --seeds: expected at most 10000 seeds, got"),
        (
            ["--cpus-per-trial", "64"],
            "--cpus-per-trial 64: this machine has 2 CPUs, so no trial could ever start",
        ),
    ],
)
def test_bad_arguments_exit_2_in_one_line_before_ray_starts(tmp_path, monkeypatch, capsys, args,
                                                            message):  # fmt: skip
    import re

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sweep_cli.os, "cpu_count", lambda: 2)
    assert sweep_cli.main(args) == 2
    err = capsys.readouterr().err
    assert len(err.splitlines()) == 1
    assert re.search(message, err), err
    assert list(tmp_path.iterdir()) == []


def test_a_terminated_sweep_exits_143_in_one_line(tmp_path, monkeypatch, capsys):
    def terminated(*args, **kwargs):
        raise sweep_cli.Terminated

    monkeypatch.setattr(sweep_cli, "run_on_tune", terminated)
    assert sweep_cli.main(["--seeds", "1", "--out", str(tmp_path / "s")]) == 143
    err = capsys.readouterr().err
    assert err.startswith("python -m warehouse_phys.sweep: terminated; finished trials keep")
    assert len(err.splitlines()) == 1


# --------------------------------------------------------------------------------- issue 32: limits
def test_a_grid_above_the_trial_limit_is_refused_at_once_before_the_address(
    tmp_path, monkeypatch, capsys
):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sweep_cli, "expand_trials", lambda *a: pytest.fail("trials were built"))
    monkeypatch.setattr(sweep_cli, "check_address", lambda *a: pytest.fail("address checked"))
    values = [str(v / 10) for v in range(1, 11)]
    argv = ["--seeds", "0-9999", "--alpha", *values, "--gamma", *values, "--address", "h:1"]
    started = time.monotonic()
    assert sweep_cli.main(argv) == 2
    assert time.monotonic() - started < 2
    assert capsys.readouterr().err == (
        "python -m warehouse_phys.sweep: error: --env, --layout, --alpha, --gamma, --episodes "
        "and --seeds ask for 1,000,000 trials, more than the 10,000 a sweep may run; split it "
        "into smaller sweeps\n"
    )
    assert list(tmp_path.iterdir()) == []


def test_the_address_is_checked_before_the_trials_are_built(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sweep_cli, "expand_trials", lambda *a: pytest.fail("trials were built"))
    assert sweep_cli.main(["--seeds", "0-9999", "--address", "127.0.0.1:1"]) == 2
    assert "--address 127.0.0.1:1: no Ray cluster answers" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []
