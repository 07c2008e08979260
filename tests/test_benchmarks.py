"""The benchmark runs and reports every figure (a smoke test with tiny budgets; no timing)."""

import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
MAPS = ROOT.parent / "shared" / "maps"
sys.path.insert(0, str(ROOT / "benchmarks"))

import bench  # noqa: E402 - the benchmark script, imported as a module


def run_bench(*args):
    return subprocess.run(
        [sys.executable, "benchmarks/bench.py", *args], cwd=ROOT, capture_output=True, text=True
    )


@pytest.mark.slow
def test_benchmark_reports_every_figure_against_its_reference(tmp_path):
    result = run_bench("--quick", "--json", str(tmp_path / "results.json"))
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[0].startswith("median of 2 interleaved round(s), CPU time")

    def row(name):
        (line,) = [line for line in lines if line.strip().startswith(f"{name} ")]
        return line

    ratio = r"\d+\.\d\dx \(\d+\.\d\d-\d+\.\d\d\)"
    for env_id in ("warehouse-robot-v0", "warehouse-robot-phys-v0"):
        for how in ("gym.make", "unwrapped"):
            assert re.search(rf"steps/s\s+{ratio}", row(f"{env_id} ({how})"))
        assert re.search(rf"frames/s\s+{ratio}", row(f"{env_id} rgb_array"))
    assert row("FrozenLake-v1 (gym.make)").endswith("reference")
    assert re.search(r">= 4x: (met|MISSED)$", row("warehouse-robot-v0 (gym.make)"))
    assert re.search(r">= 0\.4x: (met|MISSED)$", row("warehouse-robot-phys-v0 (gym.make)"))
    assert re.search(rf" s\s+{ratio}", row("trainer on warehouse-robot-phys-v0"))
    for n in (1, 64):
        assert re.search(rf"env-steps/s\s+{ratio}", row(f"native vector env, {n} envs"))
    for n in (1, 16):
        native = row(f"native physics vector env, {n} envs")
        assert re.search(rf"robot-actions/s\s+{ratio}", native)
        assert row(f"gym.make physics env, beside {n} envs").endswith("reference")
    for world in ("grid twin", "physics"):
        for n in (2, 8):
            assert re.search(rf"joint steps/s\s+{ratio}", row(f"fleet of {n}, {world}"))
    assert re.search(r">= 0\.333333x: (met|MISSED)$", row("fleet of 8, physics"))
    assert row("grid fleet of 256").rstrip().endswith("reference")  # the largest below 4,096
    assert re.search(
        rf"robot-steps/s\s+{ratio}\s+>= 0\.666667x: (met|MISSED)$", row("grid fleet of 64")
    )
    for name in ("physics fleet of 64, track_gaps=False", "physics fleet of 256"):
        assert re.search(rf"joint steps/s\s+{ratio}", row(name))
    for name in ("chipmunk's share at 256", "chipmunk's share at 256, track_gaps=False"):
        assert re.search(r"% of the CPU time\s+>= 50 % of the CPU time: (met|MISSED)$", row(name))
    assert re.search(rf"robot-steps/s\s+{ratio}", row("PIBT plan, 192 robots on warehouse"))
    assert re.search(r" us\s+" + ratio, row("physics step (move loop)"))
    for name in ("one move", "a new world", "one reset (world.restart)"):
        assert " us" in row(name)
    for size, target in ((10, 1), (100, 1), (256, 10)):
        verdict = rf"<= {target} s: (met|MISSED)$"
        assert re.search(verdict, row(f"suggested_time_limit, {size} x {size}"))

    results = json.loads((tmp_path / "results.json").read_text())
    assert results["machine"]["cpu_count"] >= 1
    assert results["timer"] == "time.process_time"
    figures = [f for section in results["sections"].values() for f in section]
    assert len(figures) == 6 + 3 + 3 + 4 + 4 + 5 + 3 + 6 + 5 + 4
    for figure in figures:
        assert len(figure["rounds"]) == results["rounds"] == 2
        assert figure["low"] <= figure["value"] <= figure["high"]
        assert figure["value"] > 0
        if figure["reference"] is not None:
            assert len(figure["ratios"]) == 2


def test_rounds_interleave_and_rotate_the_candidates():
    order = []

    def work(name):
        def run():
            order.append(name)
            return 1.0

        return run

    candidates = [bench.Candidate(name, "x/s", work(name)) for name in "abc"]
    figures = bench.interleaved(candidates, rounds=3, reference="a")
    assert order == list("abcbcacab")
    assert [len(f.rounds) for f in figures] == [3, 3, 3]
    assert figures[0].ratios == []
    assert len(figures[1].ratios) == 3


def test_a_figure_reports_the_median_and_the_median_ratio():
    figure = bench.Figure("x", "steps/s", [3.0, 1.0, 2.0], "ref", [0.5, 2.0, 1.0], target_ratio=1.5)
    assert (figure.value, figure.low, figure.high, figure.ratio) == (2.0, 1.0, 3.0, 1.0)
    assert figure.verdict == ">= 1.5x: MISSED"
    time_figure = bench.Figure("t", "s", [0.1, 0.3, 0.2], higher_is_better=False, target_value=0.25)
    assert time_figure.verdict == "<= 0.25 s: met"


def test_benchmark_refuses_an_empty_budget():
    result = run_bench("--rounds", "0")
    assert result.returncode == 2
    assert "--rounds must be at least 1" in result.stderr


@pytest.mark.slow
def test_the_lorr_benchmark_reports_our_figure_beside_the_published_one(tmp_path):
    if not (ROOT.parent / "shared" / "lorr").is_dir():
        pytest.skip("LoRR instances not found beside the checkout (../shared/lorr)")
    result = subprocess.run(
        [sys.executable, "benchmarks/lorr.py", "--quick", "--only", "EI23-200 rotate",
         "--json", str(tmp_path / "lorr.json")],
        cwd=ROOT, capture_output=True, text=True,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert re.search(
        r"EI23-200 rotate +200 robots +5 steps: .* errands/step, .* 0 refused", result.stdout
    )
    (run,) = json.loads((tmp_path / "lorr.json").read_text())["runs"]
    assert run["moves"] == "rotate"
    assert run["robots"] == 200
    assert run["peak_rss_mib"] > 0
    assert run["step_s_max"] >= run["step_s_median"] > 0


def test_the_big_maps_benchmark_reports_ours_beside_the_reference(tmp_path):
    """A smoke run: a generated floor with goals beyond the distance maps' room (guided),
    and a map read from the folder where the folder has it (kiva-33-46: the same path as
    the field's maps, on a floor 46 times smaller than warehouse_large, whose child cost
    1.5 s more); every figure is reported."""
    result = subprocess.run(
        [sys.executable, "benchmarks/big_maps.py", "--quick", "--only",
         "random-256-256-10,kiva-33-46", "--json", str(tmp_path / "big.json")],
        cwd=ROOT, capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    runs = json.loads((tmp_path / "big.json").read_text())["results"]
    generated = runs[0]
    assert generated["map"] == "random-256-256-10"
    assert generated["guided_goals"] > 0
    assert generated["full_maps"] * 2 * (generated["free_cells"] + 1) <= 2 * 2**20
    for run in runs:
        assert run["robots"] == 40  # QUICK: beyond the 2 MiB of distance maps
        assert run["first_step_ratio"] > 0
        assert run["later_step_ratio"] > 0
        assert run["peak_rss_mib"] > 0
    if (MAPS / "kiva-33-46.map").exists():
        assert [run["map"] for run in runs] == ["random-256-256-10", "kiva-33-46"]


@pytest.mark.slow
def test_the_delays_benchmark_reports_every_figure_with_no_conflict(tmp_path):
    """A smoke run of every setting (few robots, few ticks): every figure is reported,
    no run has a conflict, and the executor's runs no deadlock. On two small floors, the
    bodies on the smaller: a short run's time goes to building the floor's tables and
    shelves, and warehouse_large's (the default) cost 10 of the run's 18 s of CPU."""
    if not all((MAPS / f"{name}.map").exists() for name in ("kiva-33-46", "random-64-64-10")):
        pytest.skip("benchmark maps not found beside the checkout (../shared/maps)")
    result = subprocess.run(
        [sys.executable, "benchmarks/delays.py", "--quick", "--physics", "--maps",
         "kiva-33-46,random-64-64-10", "--physics-map", "kiva-33-46", "--json",
         str(tmp_path / "d.json"), "--plot", str(tmp_path / "d.png")],
        cwd=ROOT, capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    runs = json.loads((tmp_path / "d.json").read_text())["runs"]
    assert (tmp_path / "d.png").read_bytes()[:4] == b"\x89PNG"
    bodies = [run for run in runs if run["mode"] == "physics"]
    assert len(bodies) == 2 * 5  # ticks_per_move, pDelays: the physics twin's fleet
    for run in bodies:  # bodies read on the executor's cells, faster than real time
        assert run["disagreements"] == 0
        assert run["real_time"] > 1
        assert run["min_gap"] < 1
    runs = [run for run in runs if run["mode"] != "physics"]
    assert len(runs) == 2 * 2 * 2 * 5  # maps, ticks_per_move, modes, pDelays
    assert {run["map"] for run in runs} == {"kiva-33-46", "random-64-64-10"}
    assert {(r["mode"], r["ticks_per_move"], r["p_delay"]) for r in runs} == {
        (mode, ticks, p)
        for mode in ("lock-step", "executor")
        for ticks in (3, 10)
        for p in (0, 0.0005, 0.002, 0.005, 0.02)
    }
    for run in runs:
        assert run["vertex_conflicts"] == run["swap_conflicts"] == run["disagreements"] == 0
        assert run["errands_per_tick"] * run["ticks_per_move"] == pytest.approx(
            run["errands_per_step"]
        )
        for share in ("delayed_share", "own_delay_share", "knock_on_share"):
            assert 0 <= run[share] <= 1
        assert run["mean_drift_ticks"] >= 0
        assert run["cpu_per_move_s"] > 0
        if run["mode"] == "executor":
            assert run["deadlocks"] == 0
            assert run["executor_us_per_tick"] > 0
    # Without delays, both lock step and the executor run their first plans; with delays
    # both see the same draws, so the share of robot-ticks delayed is the same.
    pairs = {(r["map"], r["ticks_per_move"], r["p_delay"]): [] for r in runs}
    for run in runs:
        pairs[(run["map"], run["ticks_per_move"], run["p_delay"])].append(run["delayed_share"])
    assert all(len(set(shares)) == 1 for shares in pairs.values())
    assert "conflicts in all 50 runs: 0 (0: met)" in result.stdout
    assert result.stdout.count("physics twin, pDelay") == 10
    assert result.stdout.count("executor keeps") == 4
    assert result.stdout.count("executor beats lock step") == 4


def test_the_planners_benchmark_reports_guided_beside_plain_pibt(tmp_path):
    """A smoke run: the 200-robot LoRR example, two Kiva sizes and two scaling fleets
    (the scaling plot), a few steps each. The scaling fleets play the Kiva floor rather
    than warehouse_large (the default), whose tables cost 2 s of the run's 11 s of CPU."""
    shared = ROOT.parent / "shared"
    if not (shared / "lorr").is_dir() or not (MAPS / "kiva-33-46.map").exists():
        pytest.skip("LoRR instances or kiva-33-46.map not found beside the checkout")
    result = subprocess.run(
        [sys.executable, "benchmarks/planners.py", "--quick", "--json",
         str(tmp_path / "planners.json"), "--scaling", "--scaling-map",
         str(MAPS / "kiva-33-46.map"), "--plot", str(tmp_path / "scaling.png")],
        cwd=ROOT, capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    for name in ("pibt", "guided"):
        lorr_row = rf"200 robots {name} +3 steps: .* errands/step .* 0 refused"
        assert re.search(lorr_row, result.stdout)
        assert re.search(rf"kiva-33-46 +64 robots {name} .* deliveries/step .* 0 refused",
                         result.stdout)  # fmt: skip
    assert re.search(r"EI23-warehouse_large_200 congestion-free flow .* 3 steps: "
                     r"[\d.]+ errands/step", result.stdout)  # fmt: skip
    summary = json.loads((tmp_path / "planners.json").read_text())
    assert [run["planner"] for run in summary["mr23"]] == ["pibt", "guided"]
    assert summary["flow"]["steps"] == 3
    assert summary["mr23"][1]["searches_per_step"] >= 0
    assert len(summary["kiva"]) == 4
    assert summary["scaling"]["layout"] == "kiva-33-46.map"
    rows = summary["scaling"]["rows"]
    assert [(row["robots"], row["planner"]) for row in rows] == [
        (100, "pibt"), (100, "guided"), (200, "pibt"), (200, "guided")]  # fmt: skip
    assert all(row["refused"] == 0 for row in rows)
    assert (tmp_path / "scaling.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_the_planners_benchmark_plays_operations_with_turning_robots_only(tmp_path):
    """Planners over operations play the Kiva floor with turning robots; asked for
    four-direction robots they are refused in one line, before anything runs."""
    refused = subprocess.run(
        [sys.executable, "benchmarks/planners.py", "--quick", "--planners", "guided-ops"],
        cwd=ROOT, capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert refused.returncode == 2
    assert "['guided-ops'] plan turning robots: add --moves rotate" in refused.stderr
    assert "Traceback" not in refused.stderr
    if not (ROOT.parent / "shared" / "maps" / "kiva-33-46.map").exists():
        pytest.skip("kiva-33-46.map not found beside the checkout")
    result = subprocess.run(
        [sys.executable, "benchmarks/planners.py", "--quick", "--skip-lorr", "--moves",
         "rotate", "--planners", "pibt-ops,guided-ops,guided-repair", "--json",
         str(tmp_path / "p.json")],
        cwd=ROOT, capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    rows = json.loads((tmp_path / "p.json").read_text())["kiva"]
    assert [(row["planner"], row["moves"], row["refused"]) for row in rows] == [
        ("pibt-ops", "rotate", 0), ("guided-ops", "rotate", 0),
        ("guided-repair", "rotate", 0)] * 2  # fmt: skip


def test_the_guide_threads_benchmark_finds_the_same_actions_on_one_thread_and_two(tmp_path):
    """A smoke run: 40 turning robots on kiva-33-46, 3 steps, 2 rounds; the same actions
    with one worker and two, every figure printed and written; bad numbers and an unknown
    map refused in one line."""
    result = subprocess.run(
        [sys.executable, "benchmarks/guide_threads.py", "--robots", "40", "--steps", "3",
         "--rounds", "2", "--batch", "4", "--map", "kiva-33-46", "--json",
         str(tmp_path / "threads.json")],
        cwd=ROOT, capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    assert "the same actions with 1 and 2 workers: True" in result.stdout
    for name in ("1 worker", "2 workers", "sequential"):
        assert re.search(rf"{name} +\(batch +\d+\): first step [\d.]+ s wall; then \d+ ms wall",
                         result.stdout)  # fmt: skip
    assert re.search(r"1 worker / 2 workers, a step: median [\d.]+ \(rounds", result.stdout)
    summary = json.loads((tmp_path / "threads.json").read_text())
    assert summary["same_actions"]
    assert len(summary["ratio_step"]) == 2
    for args, message in ((["--steps", "1"], "--steps must be at least 2"),
                          (["--map", "nowhere"], "unknown benchmark map 'nowhere'")):  # fmt: skip
        refused = subprocess.run([sys.executable, "benchmarks/guide_threads.py", *args],
                                 cwd=ROOT, capture_output=True, text=True, check=False)  # fmt: skip
        assert refused.returncode == 2
        assert message in refused.stderr
        assert "Traceback" not in refused.stderr


@pytest.mark.slow
def test_the_physics_scale_benchmark_reports_time_memory_and_real_time(tmp_path):
    """A smoke run: two small fleets, every candidate (threads, safety), the figure, and
    the environment's pair of runs. On the Kiva floor rather than warehouse_large (the
    default): a short run's time goes to building each world's shelves (14 worlds and
    6 planners here), 7 s of the run's 18 s of CPU on warehouse_large."""
    if not (MAPS / "kiva-33-46.map").exists():
        pytest.skip("benchmark maps not found beside the checkout (../shared/maps)")
    result = subprocess.run(
        [sys.executable, "benchmarks/physics_scale.py", "--quick", "--env", "--map",
         str(MAPS / "kiva-33-46.map"), "--json", str(tmp_path / "p.json"), "--plot",
         str(tmp_path / "p.png")],
        cwd=ROOT, capture_output=True, text=True, check=False,
    )  # fmt: skip
    assert result.returncode == 0, result.stderr
    report = json.loads((tmp_path / "p.json").read_text())
    assert (tmp_path / "p.png").read_bytes()[:4] == b"\x89PNG"
    assert report["scaling"]["map"] == "kiva-33-46"
    rows = report["scaling"]["rows"]
    assert {(row["robots"], row["candidate"]) for row in rows} == {
        (n, name) for n in (100, 200)
        for name in ("1 thread", "1 thread, safety", "2 threads", "2 threads, safety")
    }  # fmt: skip
    for row in rows:
        assert row["ms_per_tick"] > 0
        assert 0 < row["critical_ms_per_tick"] <= row["ms_per_tick"] * 1.000001
        assert row["peak_mib"] > 0
    pair = report["environment"]["thousand"]
    assert pair["arrays"]["safety"]["body_contacts"] == 0
    assert pair["arrays"]["errands"] == pair["dicts"]["errands"]  # the same episode
