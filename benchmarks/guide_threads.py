"""Guide-path searches on one core and on two: the same plans, and the wall time they save.

Guided PIBT searches its robots' guide paths in batches
(:class:`~warehouse_phys.planners.guide_searches.GuideSearches`): a batch of
``search_batch`` searches runs against one flow, split over ``workers`` threads, and its
paths are the same for any number of threads. This benchmark plays the same fleet with
one worker and with two, interleaved round by round (the order rotating), and reports:

- whether every step's actions were the same with one worker as with two (they must be);
- the planner's wall time a step, median over the steps of each round, then median and
  range over the rounds, and the ratio one worker / two taken within each round, so
  that a slow moment of the machine slows both sides of it; the first step (every
  robot's first guide path) on its own;
- CPU time a step (both threads together) beside it;
- beside them, the sequential search (``search_batch=1``: each path sees every path
  before it), whose plans differ: its deliveries and its time, for what batching costs.

The floor is the package's ``kiva-140-500`` (warehouse_large's size; ``--map`` names
another of the package's maps), lifelong random packages, turning robots, seed 0: no data
from ``../shared`` is needed. The threads save
time only where a core is free: on a machine whose cores are busy the ratio falls
towards 1.

    python benchmarks/guide_threads.py [--robots N] [--steps S] [--rounds K] [--batch B]
                                       [--map NAME] [--json PATH]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import platform
import statistics
import time

import numpy as np

from warehouse_phys.envs.fleet import parallel_env
from warehouse_phys.files.atomic import atomic_write_text
from warehouse_phys.rl.fleet_planners import planner_policy
from warehouse_phys.world.maps import map_path

#: Robots, steps a round, rounds, the batch and the floor of the default run.
ROBOTS, STEPS, ROUNDS, BATCH, FLOOR = 10_000, 40, 3, 64, "kiva-140-500"


def play(
    robots: int, steps: int, batch: int, workers: int, floor: str = FLOOR
) -> dict[str, object]:
    """One run of guided PIBT, ``robots`` turning robots on the package's map ``floor``
    for ``steps`` steps with guide paths searched ``batch`` at a time on ``workers``
    threads: the planner's wall and CPU seconds a step, deliveries, and a digest of
    every action."""
    env = parallel_env(layout=str(map_path(floor)), num_robots=robots, lifelong=True,
                       max_cycles=steps, moves="rotate")  # fmt: skip
    # Every step searched ``batch`` at a time, the first too (whose own default batches
    # would otherwise make the sequential run's first step a batched one).
    policy = planner_policy("guided", seed=0, search_batch=batch,
                            first_search_batch=None, workers=workers)  # fmt: skip
    observations, infos = env.reset(seed=0)
    digest = hashlib.sha256()
    wall, cpu, delivered = [], [], 0
    for _ in range(steps):
        began_wall, began_cpu = time.perf_counter(), time.process_time()
        actions = policy(env, observations, infos)
        wall.append(time.perf_counter() - began_wall)
        cpu.append(time.process_time() - began_cpu)
        digest.update(np.array([actions[a] for a in env.agents], dtype=np.int8).tobytes())
        observations, rewards, _, _, infos = env.step(actions)
        delivered += int(sum(rewards.values()))
    env.close()
    return {"wall": wall, "cpu": cpu, "delivered": delivered, "digest": digest.hexdigest()}


def measure(
    robots: int, steps: int, rounds: int, batch: int, floor: str = FLOOR
) -> dict[str, object]:
    """The interleaved rounds (see the module): per setting, per round, the medians."""
    settings = {"1 worker": (batch, 1), "2 workers": (batch, 2), "sequential": (1, 1)}
    found: dict[str, list[dict[str, object]]] = {name: [] for name in settings}
    names = list(settings)
    for k in range(rounds):
        for name in names[k % len(names) :] + names[: k % len(names)]:
            found[name].append(play(robots, steps, *settings[name], floor))
            run = found[name][-1]
            print(f"round {k + 1} {name:<10}: first step {run['wall'][0]:.2f} s wall, then "
                  f"{1000 * statistics.median(run['wall'][1:]):.0f} ms wall "
                  f"({1000 * statistics.median(run['cpu'][1:]):.0f} ms CPU) a step, "
                  f"{run['delivered']} delivered", flush=True)  # fmt: skip
    same = all(a["digest"] == b["digest"] for a, b in zip(found["1 worker"], found["2 workers"],
                                                            strict=True))  # fmt: skip
    summary: dict[str, object] = {
        "robots": robots, "steps": steps, "rounds": rounds, "batch": batch, "map": floor,
        "same_actions": same, "cpus": os.cpu_count(), "python": platform.python_version(),
    }  # fmt: skip
    for name, runs in found.items():
        summary[name] = {
            "first_wall_s": statistics.median(r["wall"][0] for r in runs),
            "step_wall_ms": statistics.median(
                1000 * statistics.median(r["wall"][1:]) for r in runs
            ),
            "step_cpu_ms": statistics.median(1000 * statistics.median(r["cpu"][1:]) for r in runs),
            "delivered": runs[0]["delivered"],
        }
    pairs = list(zip(found["1 worker"], found["2 workers"], strict=True))
    summary["ratio_step"] = [statistics.median(a["wall"][1:]) / statistics.median(b["wall"][1:])
                             for a, b in pairs]  # fmt: skip
    summary["ratio_first"] = [a["wall"][0] / b["wall"][0] for a, b in pairs]
    return summary


def main(argv: list[str] | None = None) -> dict[str, object]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--robots", type=int, default=ROBOTS, help=f"robots ({ROBOTS:,})")
    parser.add_argument("--steps", type=int, default=STEPS, help=f"steps a run ({STEPS})")
    parser.add_argument("--rounds", type=int, default=ROUNDS, help=f"rounds ({ROUNDS})")
    parser.add_argument("--batch", type=int, default=BATCH, help=f"search_batch ({BATCH})")
    parser.add_argument("--map", default=FLOOR, help=f"a map of the package's ({FLOOR})")
    parser.add_argument("--json", help="write the summary to this JSON file")
    args = parser.parse_args(argv)
    for name in ("robots", "steps", "rounds", "batch"):
        if getattr(args, name) < (2 if name == "steps" else 1):
            parser.error(f"--{name} must be at least {2 if name == 'steps' else 1}")
    try:
        map_path(args.map)
    except ValueError as error:
        parser.error(str(error))
    summary = measure(args.robots, args.steps, args.rounds, args.batch, args.map)
    print(f"\nguided PIBT, {args.robots:,} turning robots on {args.map}, {args.steps} steps, "
          f"{args.rounds} rounds, {os.cpu_count()} CPUs, "
          f"Python {platform.python_version()}")  # fmt: skip
    print(f"the same actions with 1 and 2 workers: {summary['same_actions']}")
    for name in ("1 worker", "2 workers", "sequential"):
        row = summary[name]
        batch = 1 if name == "sequential" else args.batch
        print(f"{name:<10} (batch {batch:>3}): first step {row['first_wall_s']:.2f} s wall; "
              f"then {row['step_wall_ms']:.0f} ms wall, {row['step_cpu_ms']:.0f} ms CPU a step "
              f"(medians); {row['delivered']} delivered")  # fmt: skip
    for key, label in (("ratio_step", "a step"), ("ratio_first", "the first step")):
        ratios = summary[key]
        print(f"wall time 1 worker / 2 workers, {label}: median {statistics.median(ratios):.2f} "
              f"(rounds {min(ratios):.2f}-{max(ratios):.2f})")  # fmt: skip
    if args.json:
        atomic_write_text(args.json, json.dumps(summary, indent=2) + "\n")
    return summary


if __name__ == "__main__":
    main()
