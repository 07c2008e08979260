"""The benchmark's chipmunk-alone figure and its ``--only`` option (no timing asserted)."""

import subprocess
import sys
from pathlib import Path

import gymnasium as gym

import warehouse_phys

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "benchmarks"))

import bench  # noqa: E402 - the benchmark script, imported as a module


def test_a_candidate_may_count_only_part_of_its_cpu_time():
    candidates = [
        bench.Candidate("ref", "x/s", lambda: 1.0, cpu_seconds=lambda: 1.0),
        bench.Candidate("half", "x/s", lambda: 1.0, cpu_seconds=lambda: 0.5),
    ]
    reference, half = bench.interleaved(candidates, rounds=2, reference="ref")
    assert reference.rounds == [1.0, 1.0]
    assert half.rounds == [2.0, 2.0]
    assert half.ratios == [2.0, 2.0]


def test_chipmunk_timed_counts_the_space_steps_and_puts_the_stepping_back():
    from warehouse_phys.physics import body_io as batched  # where the batched world steps

    stepping = batched.space_stepping
    envs = gym.make_vec(warehouse_phys.PHYSICS_ENV_ID, num_envs=4)
    run, inside = bench.chipmunk_timed(bench.vector_stepper(envs, 40))
    assert run() == 40
    assert inside() > 0
    assert batched.space_stepping is stepping


def test_only_runs_the_groups_it_names():
    def bench_run(*args):
        return subprocess.run(
            [sys.executable, "benchmarks/bench.py", *args],
            cwd=ROOT,
            capture_output=True,
            text=True,
        )

    result = bench_run("--quick", "--only", "world model")
    assert result.returncode == 0, result.stderr
    assert "world model" in result.stdout
    assert "physics vector" not in result.stdout
    refused = bench_run("--quick", "--only", "nothing")
    assert refused.returncode == 2
    assert "names no group" in refused.stderr
