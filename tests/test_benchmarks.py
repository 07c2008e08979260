"""The benchmark runs and reports every figure (a smoke test with tiny budgets; no timing)."""

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def run_bench(*args):
    return subprocess.run(
        [sys.executable, "benchmarks/bench.py", *args], cwd=ROOT, capture_output=True, text=True
    )


@pytest.mark.slow
def test_benchmark_reports_every_figure_against_its_reference(tmp_path):
    result = run_bench("--quick", "--json", str(tmp_path / "results.json"))
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()

    def row(name):
        (line,) = [line for line in lines if line.strip().startswith(name)]
        return line

    for env_id in ("FrozenLake-v1", "warehouse-robot-v0", "warehouse-robot-phys-v0"):
        for how in ("gym.make", "unwrapped"):
            assert re.search(r"steps/s\s+\d+\.\d\dx", row(f"{env_id} ({how})"))
        assert re.search(r"frames/s\s+\d+\.\d\dx", row(f"{env_id} rgb_array"))
    assert re.search(r"1\.00x\s*$", row("FrozenLake-v1 (gym.make)"))
    assert re.search(r">= 1\.3x: (met|MISSED)$", row("warehouse-robot-v0 (gym.make)"))
    assert re.search(r">= 0\.15x: (met|MISSED)$", row("warehouse-robot-phys-v0 (gym.make)"))
    assert re.search(r" s\s+\d+\.\d\dx", row("trainer on warehouse-robot-phys-v0"))
    assert re.search(r"\b15 steps", row("physics steps per action"))
    for name in ("physics step (move loop)", "physics step (Space.step)", "one move", "one reset"):
        assert " us " in row(name)
    for size, target in ((10, 1), (100, 1), (256, 10)):
        assert re.search(
            rf"<= {target}(\.0)? s: (met|MISSED)$", row(f"suggested_time_limit, {size} x {size}")
        )

    results = json.loads((tmp_path / "results.json").read_text())
    assert results["machine"]["cpu_count"] >= 1
    figures = [f for section in results["sections"].values() for f in section]
    assert len(figures) == 6 + 3 + 3 + 5 + 4
    for figure in figures:
        assert figure["value"] > 0
        assert len(figure["runs"]) == results["repeats"] == 1


def test_benchmark_refuses_an_empty_budget():
    result = run_bench("--repeats", "0")
    assert result.returncode == 2
    assert "--repeats must be at least 1" in result.stderr
