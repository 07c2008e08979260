"""The benchmark scripts run and report every figure (smoke tests with tiny budgets; no timing)."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def run_benchmark(name, *args):
    result = subprocess.run(
        [sys.executable, f"benchmarks/{name}", *args], cwd=ROOT, capture_output=True, text=True
    )
    assert result.returncode == 0, result.stderr
    return result.stdout.splitlines()


@pytest.mark.slow
def test_throughput_reports_each_environment_against_frozen_lake():
    lines = run_benchmark("throughput.py", "--actions", "300", "--repeats", "1")
    for env_id in ("FrozenLake-v1", "warehouse-robot-v0", "warehouse-robot-phys-v0"):
        for how in ("gym.make", "unwrapped"):
            (row,) = [line for line in lines if line.startswith(f"{env_id} ({how})")]
            assert re.search(r"[\d,]+\s+\d+\.\d\dx$", row), row
    assert any(re.match(r"FrozenLake-v1 \(gym.make\)\s+[\d,]+\s+1\.00x$", line) for line in lines)


@pytest.mark.slow
def test_training_benchmark_reports_both_environments_against_the_tutorial():
    lines = run_benchmark("training.py", "--episodes", "30", "--repeats", "1")
    assert re.match(r"tutorial loop, grid twin \(reference\)\s+\d+\.\d{3}\s+1\.00x$", lines[1])
    assert lines[2].startswith("trainer, warehouse-robot-v0 ")
    assert lines[3].startswith("trainer, warehouse-robot-phys-v0 ")


@pytest.mark.parametrize("name", ["throughput.py", "training.py"])
def test_benchmarks_refuse_empty_budgets(name):
    result = subprocess.run(
        [sys.executable, f"benchmarks/{name}", "--repeats", "0"],
        cwd=ROOT,
        capture_output=True,
        text=True,
    )
    assert result.returncode == 2
    assert "must be at least 1" in result.stderr
