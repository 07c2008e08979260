"""The sweep on Ray: the trainable, workers that find the environments, an address
where nothing answers, and SIGTERM shutting down the Ray the sweep started."""

import json
import os
import signal
import time

import pytest

from warehouse_phys import sweep as sweep_cli
from warehouse_phys.apps.interrupts import Terminated
from warehouse_phys.apps.sweep import on_ray as sweep_ray
from warehouse_phys.apps.sweep import resume as sweep_resume
from warehouse_phys.apps.sweep import trials as sweep_trials


def test_a_trial_writes_the_same_run_folder_as_the_trainer(tmp_path):
    args = sweep_cli.build_parser().parse_args(["--seeds", "1", "--episodes", "80"])
    (trial,) = sweep_trials.trials_from_args(args)
    measures = sweep_ray.run_trial(trial.to_job(tmp_path, gif=False))
    folder = tmp_path / trial.folder
    summary = json.loads((folder / "summary.json").read_text())
    assert summary["config"] == {"episodes": 80, "alpha": 0.9, "gamma": 0.9, "seed": 0}
    assert measures["training_episodes"] == 80
    assert measures["optimal"] == summary["evaluation"]["optimal"]
    assert sweep_resume.finished_row(trial, tmp_path)["status"] == "done"


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
    # A refused argument: exit status 2, as docs/limits.md promises for every command line.
    monkeypatch.chdir(tmp_path)
    started = time.monotonic()
    assert sweep_cli.main(["--seeds", "1", "--address", "127.0.0.1:1"]) == 2
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
    assert sweep_cli.main(["--seeds", "1", "--address", "auto", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err == f"python -m warehouse_phys.sweep: error: --address auto: {message}\n"
    assert not out.exists()
    # Without --out: neither the sweep's timestamped folder nor sweeps/ is left.
    monkeypatch.chdir(tmp_path)
    assert sweep_cli.main(["--seeds", "1", "--address", "auto", "--quiet"]) == 2
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    ("address", "status"), [(None, 1), ("auto", 2), ("local", 1), ("10.0.0.1:6379", 2)]
)
def test_a_refused_address_exits_2_and_a_local_ray_that_cannot_start_1(
    tmp_path, monkeypatch, capsys, address, status
):
    import ray

    def cannot(**kwargs):
        raise RuntimeError("no room for Ray's object store\nmore lines")

    monkeypatch.setattr(ray, "init", cannot)
    monkeypatch.setattr(sweep_ray, "check_address", lambda address: None)  # 10.0.0.1 answers
    monkeypatch.setattr(sweep_cli, "check_address", lambda address: None)
    monkeypatch.chdir(tmp_path)
    given = [] if address is None else ["--address", address]
    assert sweep_cli.main(["--seeds", "1", "--quiet", *given]) == status
    where = "cannot start a local Ray" if address is None else f"--address {address}"
    assert capsys.readouterr().err == (
        f"python -m warehouse_phys.sweep: error: {where}: no room for Ray's object store\n"
    )
    assert list(tmp_path.iterdir()) == []


def test_sigterm_shuts_down_the_ray_it_started(monkeypatch):
    import ray

    calls = []
    monkeypatch.setattr(ray, "is_initialized", lambda: False)
    monkeypatch.setattr(ray, "init", lambda **kwargs: calls.append("init"))
    monkeypatch.setattr(ray, "shutdown", lambda: calls.append("shutdown"))
    before = signal.getsignal(signal.SIGTERM)

    def sweep_killed():
        with sweep_ray.ray_session(None, 1):
            os.kill(os.getpid(), signal.SIGTERM)
            time.sleep(5)  # interrupted at once

    started = time.monotonic()
    with pytest.raises(Terminated):
        sweep_killed()
    assert time.monotonic() - started < 4
    assert calls == ["init", "shutdown"]
    assert signal.getsignal(signal.SIGTERM) == before


def test_the_sweeps_local_ray_prestarts_no_idle_workers_and_a_cluster_keeps_its_own(
    monkeypatch, tmp_path
):
    """Tune runs the trials in workers of their own, so the sweep's local Ray starts no
    idle ones ahead of them; a cluster's settings and a session of the default are Ray's."""
    import ray

    inits = []
    monkeypatch.setattr(ray, "is_initialized", lambda: False)
    monkeypatch.setattr(ray, "init", lambda **kwargs: inits.append(kwargs))
    monkeypatch.setattr(ray, "shutdown", lambda: None)
    monkeypatch.setattr(ray, "cluster_resources", lambda: {"CPU": 2})
    monkeypatch.setattr(sweep_ray, "check_address", lambda address: None)
    with sweep_ray.ray_session(None, 1, prestart_workers=False):
        pass
    with sweep_ray.ray_session("10.0.0.1:6379", 1, prestart_workers=False):
        pass
    with sweep_ray.ray_session(None, 1):
        pass
    assert inits[0]["_system_config"] == {"prestart_worker_first_driver": False}
    assert ["_system_config" in init for init in inits[1:]] == [False, False]

    class Recorded(Exception):
        """The sweep's session, asked for and recorded, not started."""

    def recorded_session(*args, **kwargs):
        raise Recorded(args, kwargs)

    monkeypatch.setattr(sweep_ray, "ray_session", recorded_session)
    with pytest.raises(Recorded) as asked:
        sweep_ray.run_on_tune([], tmp_path, address=None, cpus_per_trial=1,
                              max_concurrent=None, quiet=True)  # fmt: skip
    assert asked.value.args == ((None, 1), {"prestart_workers": False})
