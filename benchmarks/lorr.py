"""The League of Robot Runners' own instances: our figures beside the published ones.

Each run plays the PIBT planner (:func:`warehouse_phys.planners.pibt.pibt_policy`) on one
instance of ``../shared/lorr`` for 5,000 steps, as the competition counts, in a fresh
process on one core (numpy's threads held to one), and measures:

- errands and tasks finished a step (the competition's counts: in 2023 a task is one
  errand; in 2024 a task is two), refused moves;
- CPU time (``time.process_time``): the instance's reading, the reset (the first
  errands' distance maps), the first step, the median and slowest later step; the
  errand list's own bookkeeping (handing out tasks, the scheduler) per step. As
  ``simulate`` does, the objects built before the run are frozen out of Python's full
  garbage collections (``gc.freeze``), which otherwise walk a large floor's cells;
- the process's peak resident memory.

Runs: MR23-I-10 (10,000 robots, 2023 record 38.9 errands a step) with four-direction and
turning robots; 2024 WAREHOUSE (10,000 robots, 100,000 two-stop tasks; record 30.97 and
default entry 12.78 tasks a step) with turning robots and the nearest pairing; the
2023 example instances with 200, 1,000 and 5,000 robots, both move models.

    python benchmarks/lorr.py [--steps 5000] [--only NAME[,NAME]] [--json PATH] [--quick]

``--quick`` runs every instance for a few steps (a smoke test).
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import platform
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

# One core: numpy's threads too.
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

from warehouse_phys.envs.fleet import parallel_env
from warehouse_phys.files.atomic import atomic_write_text
from warehouse_phys.lorr.instances import PUBLISHED_FIGURES, SCHEDULED, read_instance
from warehouse_phys.lorr.scheduling import nearest_free_robot
from warehouse_phys.rl.fleet_planners import pibt_policy

LORR = Path(__file__).resolve().parents[2] / "shared" / "lorr"
#: name -> (instance path under ../shared/lorr, move model)
RUNS: dict[str, tuple[str, str]] = {
    "MR23-I-10 grid": ("2023-main-warehouse/MR23-I-10.json", "grid"),
    "MR23-I-10 rotate": ("2023-main-warehouse/MR23-I-10.json", "rotate"),
    "WAREHOUSE rotate": ("2024-main-warehouse/WAREHOUSE.json", "rotate"),
    **{
        f"EI23-{n} {moves}": (f"2023-examples-warehouse/EI23-warehouse_large_{n}.json", moves)
        for n in (200, 1000, 5000)
        for moves in ("grid", "rotate")
    },
}


def run_one(name: str, steps: int) -> dict[str, object]:
    """One run in this process (see the module); its figures."""
    relative, moves = RUNS[name]
    start = time.process_time()
    instance = read_instance(LORR / relative)
    read_s = time.process_time() - start
    # 2024: the nearest pairing, the scheduler of the published table (docs/lorr.md); the
    # fleet's default now rematches (benchmarks/planners.py --scheduler measures that).
    scheduled = {"scheduler": nearest_free_robot} if instance.assignment == SCHEDULED else {}
    env = parallel_env(instance=instance, moves=moves, max_cycles=steps, **scheduled)
    errands = env.errands
    bookkeeping: list[float] = []
    step_errands = errands.step

    def timed_step(arrived, here):  # noqa: ANN001, ANN202 - the errand list's own step
        begun = time.process_time()
        finished = step_errands(arrived, here)
        bookkeeping.append(time.process_time() - begun)
        return finished

    errands.step = timed_step
    policy = pibt_policy(seed=0)
    gc.freeze()  # as simulate does: the floor's objects leave Python's full collections
    start = time.process_time()
    observations, infos = env.reset(seed=0)
    reset_s = time.process_time() - start
    step_s, refused = [], 0
    for _ in range(steps):
        begun = time.process_time()
        actions = policy(env, observations, infos)
        observations, _, _, _, infos = env.step(actions)
        step_s.append(time.process_time() - begun)
        refused += sum(info["refused"] for info in infos.values())
    later = step_s[1:] or step_s
    published = PUBLISHED_FIGURES.get(instance.name)
    return {
        "name": name,
        "instance": instance.name,
        "moves": moves,
        "robots": instance.team_size,
        "steps": steps,
        "errands_per_step": errands.errands_done / steps,
        "tasks_per_step": errands.tasks_done / steps,
        "refused": refused,
        "read_s": read_s,
        "reset_s": reset_s,
        "first_step_s": step_s[0],
        "step_s_median": statistics.median(later),
        "step_s_max": max(later),
        "errand_bookkeeping_ms_median": 1000 * statistics.median(bookkeeping),
        "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "published": None if published is None else published.to_json(),
    }


def describe(result: dict[str, object]) -> str:
    published = PUBLISHED_FIGURES.get(str(result["instance"]))
    beside = "" if published is None else f"; published: {published.describe()}"
    return (
        f"{result['name']:<18} {result['robots']:>6,} robots {result['steps']:>5} steps: "
        f"{result['errands_per_step']:6.2f} errands/step, {result['tasks_per_step']:6.2f} "
        f"tasks/step, {result['refused']} refused; read {result['read_s']:.2f} s, reset "
        f"{result['reset_s']:.1f} s, first step {result['first_step_s']:.2f} s, then "
        f"{result['step_s_median'] * 1000:.0f} ms/step (max {result['step_s_max'] * 1000:.0f}), "
        f"errands {result['errand_bookkeeping_ms_median']:.2f} ms/step; peak "
        f"{result['peak_rss_mib']:,.0f} MiB{beside}"
    )


def main(argv: list[str] | None = None) -> dict[str, object]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=5000, help="steps a run (default 5000)")
    parser.add_argument("--only", help="comma-separated run names (default: every run)")
    parser.add_argument("--quick", action="store_true", help="a few steps each: a smoke test")
    parser.add_argument("--json", type=Path, help="write the results to this JSON file")
    parser.add_argument("--one", help=argparse.SUPPRESS)  # a run in a fresh process
    args = parser.parse_args(argv)
    steps = 5 if args.quick else args.steps
    if args.one is not None:
        print(json.dumps(run_one(args.one, steps)))
        return {}
    if not LORR.is_dir():
        print(f"skipped: the LoRR instances are not at {LORR}")
        return {}
    names = list(RUNS) if args.only is None else args.only.split(",")
    unknown = [name for name in names if name not in RUNS]
    if unknown:
        parser.error(f"unknown runs {unknown}; known: {list(RUNS)}")
    print(f"CPU time, one core; Python {platform.python_version()}, {os.cpu_count()} CPUs",
          flush=True)  # fmt: skip
    results = []
    for name in names:
        done = subprocess.run(
            [sys.executable, __file__, "--one", name, "--steps", str(steps)],
            capture_output=True, text=True, check=False,
        )  # fmt: skip
        if done.returncode != 0:
            print(f"{name}: failed: {done.stderr.strip().splitlines()[-1:]}", flush=True)
            continue
        results.append(json.loads(done.stdout.strip().splitlines()[-1]))
        print(describe(results[-1]), flush=True)
    summary = {"created": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "python": sys.version,
               "timer": "time.process_time", "runs": results}  # fmt: skip
    if args.json is not None:
        atomic_write_text(args.json, json.dumps(summary, indent=2) + "\n")
        print(f"wrote {args.json}")
    return summary


if __name__ == "__main__":
    main()
