"""``python -m warehouse_phys.sweep`` on a real local Ray: results, resuming, failures."""

import csv
import json
import os
import signal
import subprocess
import sys
import time

import gymnasium as gym
import pytest

from warehouse_phys import sweep as sweep_cli
from warehouse_phys.apps.runs import RUN_FILES
from warehouse_phys.rl.qlearning import evaluate, load_q_table

SWEEP = ["--env", "grid", "phys", "--seeds", "2", "--episodes", "60"]
BLOCKED = "runs/phys-default-a0.9-g0.9-e60-seed1"


def run_sweep(*args, cwd):
    return subprocess.run(
        [sys.executable, "-m", "warehouse_phys.apps.sweep", *args],
        cwd=cwd, capture_output=True, text=True, timeout=300,
    )  # fmt: skip


def read_rows(folder):
    with (folder / "results.csv").open() as file:
        return list(csv.DictReader(file))


@pytest.mark.slow
def test_a_sweep_on_ray_records_every_trial_resumes_and_reports_failures(tmp_path):
    out = tmp_path / "sweep"
    (out / "runs").mkdir(parents=True)
    (out / BLOCKED).write_text("in the way")  # this trial's folder cannot be written

    first = run_sweep(*SWEEP, "--out", str(out), cwd=tmp_path)
    assert first.returncode == 1, first.stderr
    assert "Traceback" not in first.stderr
    assert first.stderr.strip().endswith(f"1 of 4 trials failed; see {out / 'results.csv'}")
    assert first.stdout.startswith(f"4 trials in {out}: 0 already finished, 4 to run\n")
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
        assert sorted(p.name for p in folder.iterdir()) == sorted(set(RUN_FILES) - {"episode.gif"})
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

    # The same command again, the obstacle gone: only the failed trial trains.
    (out / BLOCKED).unlink()
    second = run_sweep(*SWEEP, "--out", str(out), cwd=tmp_path)
    assert second.returncode == 0, second.stderr
    assert second.stdout.startswith(f"4 trials in {out}: 3 already finished, 1 to run\n")
    assert "[1/1] phys-default-a0.9-g0.9-e60-seed1: done" in second.stdout
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


def test_the_grid_of_trials_is_every_combination_in_order():
    argv = ["--env", "grid", "phys", "--layout", "default", "maze", "--seeds", "3-4"]
    argv += ["--alpha", "0.5", "0.9"]
    args = sweep_cli.build_parser().parse_args(argv)
    trials = sweep_cli.trials_from_args(args)
    assert len(trials) == 2 * 2 * 2 * 2
    assert trials[0].name == "grid-default-a0.5-g0.9-e1000-seed3"
    maze = [t for t in trials if t.floor_name == "maze"]
    assert {t.episodes for t in maze} == {5000}  # the preset's own training episodes
    assert len({t.folder for t in trials}) == len(trials)


def test_a_trial_writes_the_same_run_folder_as_the_trainer(tmp_path):
    args = sweep_cli.build_parser().parse_args(["--seeds", "1", "--episodes", "80"])
    (trial,) = sweep_cli.trials_from_args(args)
    measures = sweep_cli.run_trial(trial.to_job(tmp_path, gif=False))
    folder = tmp_path / trial.folder
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["config"] == {"episodes": 80, "alpha": 0.9, "gamma": 0.9, "seed": 0}
    assert measures["training_episodes"] == 80
    assert measures["optimal"] == summary["evaluation"]["optimal"]
    assert sweep_cli.finished_row(trial, tmp_path)["status"] == "done"


SPAWN_SNIPPET = """
import gymnasium as gym
import numpy as np

# Ids in "warehouse_phys:" form register the package inside each spawned worker.
envs = gym.vector.AsyncVectorEnv(
    [lambda: gym.make("warehouse_phys:warehouse-robot-v0") for _ in range(2)], context="spawn"
)
obs, infos = envs.reset(seed=0)
obs, rewards, terminations, truncations, infos = envs.step(np.array([2, 1]))
envs.close()
print(obs.shape)
"""


@pytest.mark.slow
def test_spawned_workers_find_the_environments_by_their_module_ids(run_python):
    # Started with -c: no script file, as from a notebook or a REPL.
    assert run_python(SPAWN_SNIPPET, timeout=120).strip() == "(2, 4)"


# ------------------------------------------------- nothing hangs, nothing is left
def test_an_address_where_nothing_listens_fails_within_seconds(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    started = time.monotonic()
    assert sweep_cli.main(["--seeds", "1", "--address", "127.0.0.1:1"]) == 1
    assert time.monotonic() - started < 10
    assert capsys.readouterr().err == (
        "python -m warehouse_phys.sweep: error: --address 127.0.0.1:1: no Ray cluster answers: "
        "Connection refused\n"
    )
    assert list(tmp_path.iterdir()) == []


def test_no_cluster_at_auto_is_one_line_and_leaves_no_folder(tmp_path, monkeypatch, capsys):
    import ray

    message = "Could not find any running Ray instance. Please specify the one to connect to."

    def no_cluster(**kwargs):
        raise ConnectionError(message)

    monkeypatch.setattr(ray, "init", no_cluster)
    out = tmp_path / "sweep"
    assert sweep_cli.main(["--seeds", "1", "--address", "auto", "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert err == f"python -m warehouse_phys.sweep: error: --address auto: {message}\n"
    assert not out.exists()


def test_a_folder_of_other_files_is_refused(tmp_path, capsys):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "notes.txt").write_text("keep")
    (out / "runs").mkdir()
    assert sweep_cli.main(["--seeds", "1", "--out", str(out)]) == 2
    assert capsys.readouterr().err == (
        f"python -m warehouse_phys.sweep: error: --out {out} holds files that are not a "
        "sweep's (notes.txt); choose a new or empty folder, or an earlier sweep's folder to "
        "resume it\n"
    )
    assert sorted(p.name for p in out.iterdir()) == ["notes.txt", "runs"]
    (out / "notes.txt").unlink()
    (out / ".results.csv.x1y2.tmp").write_text("")  # a killed sweep's half-written table
    sweep_cli.check_sweep_folder(out)  # an earlier sweep's folder: resumed


def test_sigterm_shuts_down_the_ray_it_started(monkeypatch):
    import ray

    calls = []
    monkeypatch.setattr(ray, "is_initialized", lambda: False)
    monkeypatch.setattr(ray, "init", lambda **kwargs: calls.append("init"))
    monkeypatch.setattr(ray, "shutdown", lambda: calls.append("shutdown"))
    before = signal.getsignal(signal.SIGTERM)

    def sweep_killed():
        with sweep_cli.ray_session(None, 1):
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(5)  # interrupted at once

    started = time.monotonic()
    with pytest.raises(sweep_cli.Terminated):
        sweep_killed()
    assert time.monotonic() - started < 4
    assert calls == ["init", "shutdown"]
    assert signal.getsignal(signal.SIGTERM) == before


def test_a_terminated_sweep_exits_143_in_one_line(tmp_path, monkeypatch, capsys):
    def terminated(*args, **kwargs):
        raise sweep_cli.Terminated

    monkeypatch.setattr(sweep_cli, "run_on_tune", terminated)
    assert sweep_cli.main(["--seeds", "1", "--out", str(tmp_path / "s")]) == 143
    err = capsys.readouterr().err
    assert err.startswith("python -m warehouse_phys.sweep: terminated; finished trials keep")
    assert len(err.splitlines()) == 1


# ------------------------------------------------------------ issue 32: limits, resume, lingering
def tune_in_process(jobs, sweep_dir, **options):
    """``run_on_tune`` without Ray: every job in this process, its error kept as Tune keeps it."""
    outcomes = {}
    for job in jobs:
        try:
            outcomes[job["name"]] = sweep_cli.run_trial(job)
        except Exception as error:
            outcomes[job["name"]] = error
    return outcomes


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


def test_the_trial_limit_counts_every_axis_and_allows_exactly_the_limit():
    parse = sweep_cli.build_parser().parse_args
    assert sweep_cli.MAX_TRIALS == sweep_cli.MAX_SEEDS  # the most seeds alone still fit
    assert len(sweep_cli.trials_from_args(parse(["--seeds", "0-9999"]))) == 10_000
    with pytest.raises(sweep_cli.UsageError, match="ask for 10,002 trials"):
        sweep_cli.settings_from_args(parse(["--seeds", "5001", "--episodes", "10", "20"]))
    with pytest.raises(sweep_cli.UsageError, match="ask for 10,100 trials"):
        sweep_cli.settings_from_args(parse(["--env", "grid", "phys", "--seeds", "5050"]))


def test_the_address_is_checked_before_the_trials_are_built(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sweep_cli, "expand_trials", lambda *a: pytest.fail("trials were built"))
    assert sweep_cli.main(["--seeds", "0-9999", "--address", "127.0.0.1:1"]) == 1
    assert "--address 127.0.0.1:1: no Ray cluster answers" in capsys.readouterr().err


def finished_sweep(tmp_path, monkeypatch, capsys):
    """A two-trial sweep run in this process: its folder and the trials."""
    monkeypatch.setattr(sweep_cli, "run_on_tune", tune_in_process)
    out = tmp_path / "sweep"
    argv = ["--seeds", "2", "--episodes", "60", "--out", str(out)]
    assert sweep_cli.main(argv) == 0, capsys.readouterr().err
    assert "2 trials in" in capsys.readouterr().out
    trials = sweep_cli.trials_from_args(sweep_cli.build_parser().parse_args(argv))
    return out, argv, trials


def test_a_truncated_or_foreign_table_is_trained_again_on_resume(tmp_path, monkeypatch, capsys):
    out, argv, trials = finished_sweep(tmp_path, monkeypatch, capsys)
    assert all(sweep_cli.finished_row(trial, out) for trial in trials)
    table = out / trials[1].folder / "qtable.npz"
    data = table.read_bytes()
    table.write_bytes(data[: len(data) // 2])  # the summary still says done
    assert sweep_cli.finished_row(trials[1], out) is None
    assert sweep_cli.finished_row(trials[0], out)["status"] == "done"

    assert sweep_cli.main(argv) == 0
    assert f"2 trials in {out}: 1 already finished, 1 to run" in capsys.readouterr().out
    _, metadata = load_q_table(table)
    assert metadata["seed"] == 1
    # Seed 0's table in seed 1's folder: it loads, but is not this trial's run.
    table.write_bytes((out / trials[0].folder / "qtable.npz").read_bytes())
    assert sweep_cli.finished_row(trials[1], out) is None


def test_a_sweep_folder_in_use_by_a_live_sweep_is_refused_naming_its_pid(tmp_path, capsys):
    out = tmp_path / "sweep"
    out.mkdir()
    handle, token = sweep_cli.take_sweep_lock(out)  # a live driver: this process
    try:
        assert token.split()[0] == str(os.getpid())
        assert sweep_cli.main(["--seeds", "1", "--out", str(out)]) == 2
        assert capsys.readouterr().err == (
            f"python -m warehouse_phys.sweep: error: --out {out} is in use by the sweep of "
            f"process {os.getpid()}; wait for it to end or choose another folder\n"
        )
        assert sorted(p.name for p in out.iterdir()) == ["sweep.lock"]
    finally:
        os.close(handle)


def test_a_killed_drivers_lock_is_taken_over_with_a_new_token(tmp_path, monkeypatch, capsys):
    out = tmp_path / "sweep"
    out.mkdir()
    (out / "sweep.lock").write_text("4194304 0123456789abcdef\n")  # no process holds it
    monkeypatch.setattr(sweep_cli, "run_on_tune", tune_in_process)
    assert sweep_cli.main(["--seeds", "1", "--episodes", "30", "--out", str(out)]) == 0
    pid, token = (out / "sweep.lock").read_text().split()
    assert pid == str(os.getpid())
    assert len(token) == 32
    sweep_cli.check_sweep_folder(out)  # the lock is one of the sweep's own files


def test_a_lingering_worker_of_an_earlier_run_touches_nothing(tmp_path, monkeypatch, capsys):
    out, _, trials = finished_sweep(tmp_path, monkeypatch, capsys)
    folder = out / trials[0].folder
    before = {p.name: p.stat().st_mtime_ns for p in folder.iterdir()}
    old_job = trials[0].to_job(out, gif=False, run="1 earlier-run")  # not the lock's token
    with pytest.raises(sweep_cli.SupersededError, match=r"a newer run .* owns the folder"):
        sweep_cli.run_trial(old_job)
    assert {p.name: p.stat().st_mtime_ns for p in folder.iterdir()} == before
    # A trial of the current run, the token in the lock file, trains as ever.
    current = (out / "sweep.lock").read_text().strip()
    assert sweep_cli.run_trial(trials[0].to_job(out, gif=False, run=current))["optimal"] >= 0


def hold_folder(folder):
    """Lock ``folder`` as a run writing it does; returns the handle that releases it."""
    import fcntl

    handle = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    fcntl.flock(handle, fcntl.LOCK_EX | fcntl.LOCK_NB)
    return handle


def held(folder):
    """Whether a process holds ``folder``'s lock (a run writing it)."""
    import fcntl

    handle = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    try:
        fcntl.flock(handle, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except BlockingIOError:
        return True
    finally:
        os.close(handle)
    return False


def test_a_folder_held_by_a_lingering_worker_is_not_finished_and_is_waited_for(
    tmp_path, monkeypatch, capsys
):
    import threading

    out, _, trials = finished_sweep(tmp_path, monkeypatch, capsys)
    folder = out / trials[0].folder
    handle = hold_folder(folder)
    try:
        assert sweep_cli.finished_row(trials[0], out) is None  # it may be half-written
        monkeypatch.setattr(sweep_cli, "FOLDER_WAIT", 0.2)
        with pytest.raises(sweep_cli.RunFolderError, match="in use by another run"):
            sweep_cli.run_trial(trials[0].to_job(out, gif=False))
        monkeypatch.setattr(sweep_cli, "FOLDER_WAIT", 60.0)
        results = []
        worker = threading.Thread(
            target=lambda: results.append(sweep_cli.run_trial(trials[0].to_job(out, gif=False)))
        )
        worker.start()
        time.sleep(1.0)
        assert worker.is_alive()  # waiting for the folder
        assert not results
    finally:
        os.close(handle)
    worker.join(60)
    assert [r["training_episodes"] for r in results] == [60]
    assert sweep_cli.finished_row(trials[0], out)["status"] == "done"


#: Loaded by every Python process of the killed sweep, its Ray workers included: a trial
#: there stalls with its folder locked, and a process of its own keeps the folder's lock
#: for 20 s (a worker that Ray is slow to end, as under load).
STALL_TRIALS = """
import importlib.util
import subprocess
import sys
import time


class StallTrials:
    def find_spec(self, name, path=None, target=None):
        if name != "warehouse_phys.apps.runs":
            return None
        sys.meta_path.remove(self)
        spec = importlib.util.find_spec(name)
        run_module = spec.loader.exec_module

        def exec_module(module):
            run_module(module)

            def train_run(folder, *args, **kwargs):
                # Detached ("&"): Ray ends a worker's children with it, not this one.
                subprocess.Popen(["sh", "-c", "sleep 20 &"], pass_fds=[folder._handle])
                time.sleep(600)

            module.train_run = train_run

        spec.loader.exec_module = exec_module
        return spec


sys.meta_path.insert(0, StallTrials())
"""


@pytest.mark.slow
def test_a_sweep_run_again_at_once_after_its_driver_is_killed_succeeds(tmp_path):
    # A worker of the killed driver lingers, the trial's folder locked, while the new run
    # starts: the new run's worker waits for the folder (it failed "in use" before).
    hook = tmp_path / "hook"
    hook.mkdir()
    (hook / "sitecustomize.py").write_text(STALL_TRIALS)
    out = tmp_path / "sweep"
    argv = ["--seeds", "1", "--episodes", "60", "--out", str(out), "--quiet"]
    folder = out / "runs/grid-default-a0.9-g0.9-e60-seed0"
    driver = subprocess.Popen(
        [sys.executable, "-m", "warehouse_phys.apps.sweep", *argv], cwd=tmp_path,
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        env={**os.environ, "PYTHONPATH": os.pathsep.join([str(hook), *sys.path])},
    )  # fmt: skip
    try:
        deadline = time.monotonic() + 120
        while not (folder.is_dir() and held(folder)):
            assert driver.poll() is None, "the sweep ended before its trial started"
            assert time.monotonic() < deadline, "the trial never started"
            time.sleep(0.1)
    finally:
        driver.kill()  # SIGKILL: Ray is not shut down
        driver.wait()
    again = run_sweep(*argv, cwd=tmp_path)
    assert again.returncode == 0, again.stderr
    assert [row["status"] for row in read_rows(out)] == ["done"]
    _, metadata = load_q_table(folder / "qtable.npz")
    assert metadata["episodes"] == 60
    assert (out / "sweep.lock").read_text().split()[0] != str(driver.pid)
