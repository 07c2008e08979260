"""A fleet at warehouse scale: throughput on the field's maps, and time per step at 10,000 robots.

Two measurements, on the MovingAI maps of ``../shared/maps`` (the floor's own
``warehouse`` preset stands in for ``kiva-33-46.map`` when the folder is absent):

- throughput: lifelong deliveries per step of a policy (``pibt`` by default, and
  the baselines with ``--policies``) on ``kiva-33-46.map``, 256 steps, seeds 0-4,
  at 128 and 192 robots, as the field reports it (POGEMA, the League of Robot
  Runners); robots start on distinct cells drawn from the seed;
- scale: 10,000 robots on ``warehouse-large-140-500.map``, lifelong: the CPU time
  of the first step (reset, the distance maps of 10,000 packages, the plan, the
  step), then of each later step split into planner and environment, the memory
  of the distance maps, and the throughput over the steps.

Times are CPU times (``time.process_time``); the machine is shared, so each is a
median over steps.

    python benchmarks/fleet_scale.py [--quick] [--policies pibt,shortest,random]
        [--skip-scale] [--json PATH]
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

from warehouse_phys.envs.fleet import parallel_env
from warehouse_phys.files.atomic import atomic_write_text
from warehouse_phys.rl.fleet_evaluation import random_fleet_policy, shortest_path_policy
from warehouse_phys.rl.fleet_planners import pibt_policy

MAPS = Path(__file__).resolve().parents[2] / "shared" / "maps"
#: Published lifelong throughput on the 33 x 46 warehouse, 192 robots, 256 steps
#: [deliveries/step] (POGEMA's benchmark of learned and classic planners).
PUBLISHED_KIVA_192 = {"Follower (learned)": 3.94, "QMIX": 2.0, "RHCR": 1.57, "IQL": 0.36}


def make_policy(name: str, seed: int):  # noqa: ANN201 - a FleetPolicy
    """The named policy, seeded."""
    if name == "pibt":
        return pibt_policy(seed=seed)
    if name == "shortest":
        return shortest_path_policy
    if name == "random":
        return random_fleet_policy(seed)
    raise ValueError(f"unknown policy {name!r}")


def run_lifelong(env, policy, seed: int, steps: int) -> dict[str, object]:  # noqa: ANN001
    """Play ``policy`` for ``steps`` joint steps from ``env.reset(seed=seed)``; the
    throughput, the refused moves, and the CPU time of each step's plan and env step."""
    observations, infos = env.reset(seed=seed)
    plan_times, step_times, refused, delivered = [], [], 0, 0
    for _ in range(steps):
        start = time.process_time()
        actions = policy(env, observations, infos)
        planned = time.process_time()
        observations, rewards, _, _, infos = env.step(actions)
        stepped = time.process_time()
        plan_times.append(planned - start)
        step_times.append(stepped - planned)
        delivered += int(sum(rewards.values()))
        refused += sum(info["refused"] for info in infos.values())
    return {
        "throughput": delivered / steps,
        "delivered": delivered,
        "refused": refused,
        "plan_s": plan_times,
        "step_s": step_times,
    }


def kiva_layout() -> str:
    path = MAPS / "kiva-33-46.map"
    return str(path) if path.exists() else "warehouse"


def throughput_table(
    policies: list[str], robots: list[int], seeds: list[int], steps: int
) -> list[dict[str, object]]:
    layout = kiva_layout()
    rows = []
    for n in robots:
        env = parallel_env(num_robots=n, layout=layout, on_delivery="new_package",
                           max_cycles=steps)  # fmt: skip
        for name in policies:
            runs = [run_lifelong(env, make_policy(name, seed), seed, steps) for seed in seeds]
            values = [run["throughput"] for run in runs]
            rows.append(
                {
                    "layout": Path(layout).name,
                    "robots": n,
                    "policy": name,
                    "throughput": statistics.fmean(values),
                    "per_seed": values,
                    "refused": sum(run["refused"] for run in runs),
                    "plan_ms_per_step": 1000
                    * statistics.median(t for run in runs for t in run["plan_s"]),
                }
            )
            row = rows[-1]
            print(
                f"{row['layout']:<16} {n:>6} robots  {name:<9} "
                f"{row['throughput']:6.2f} deliveries/step "
                f"(seeds {min(values):.2f}-{max(values):.2f}), {row['refused']} refused, "
                f"plan {row['plan_ms_per_step']:.1f} ms/step",
                flush=True,
            )
    return rows


def scale_run(robots: int, steps: int, seed: int = 0) -> dict[str, object]:
    path = MAPS / "warehouse-large-140-500.map"
    if not path.exists():
        print(f"scale: skipped, {path} is absent")
        return {}
    start = time.process_time()
    env = parallel_env(num_robots=robots, layout=str(path), on_delivery="new_package",
                       max_cycles=steps + 1)  # fmt: skip
    built = time.process_time() - start
    policy = pibt_policy(seed=seed)
    start = time.process_time()
    observations, infos = env.reset(seed=seed)
    actions = policy(env, observations, infos)
    observations, rewards, _, _, infos = env.step(actions)
    first = time.process_time() - start
    delivered = int(sum(rewards.values()))
    refused = sum(info["refused"] for info in infos.values())
    plan_times, step_times = [], []
    for _ in range(steps - 1):
        start = time.process_time()
        actions = policy(env, observations, infos)
        planned = time.process_time()
        observations, rewards, _, _, infos = env.step(actions)
        stepped = time.process_time()
        plan_times.append(planned - start)
        step_times.append(stepped - planned)
        delivered += int(sum(rewards.values()))
        refused += sum(info["refused"] for info in infos.values())
    totals = [p + s for p, s in zip(plan_times, step_times, strict=True)]
    result = {
        "robots": robots,
        "steps": steps,
        "build_s": built,
        "first_step_s": first,
        "plan_s_median": statistics.median(plan_times),
        "env_step_s_median": statistics.median(step_times),
        "step_s_median": statistics.median(totals),
        "step_s_max": max(totals),
        "distance_map_mib": env.distances.nbytes / 2**20,
        "throughput": delivered / steps,
        "refused": refused,
    }
    print(
        f"{robots:,} robots on {path.name}: env built in {built:.2f} s; first step "
        f"(reset, distance maps, plan, step) {first:.1f} s; then per step: planner "
        f"{result['plan_s_median'] * 1000:.0f} ms + env {result['env_step_s_median'] * 1000:.0f} "
        f"ms = {result['step_s_median'] * 1000:.0f} ms (median; max "
        f"{result['step_s_max'] * 1000:.0f} ms); distance maps {result['distance_map_mib']:.0f} "
        f"MiB; throughput {result['throughput']:.2f} deliveries/step over {steps} steps, "
        f"{refused} refused",
        flush=True,
    )
    return result


def main(argv: list[str] | None = None) -> dict[str, object]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="tiny budgets: a smoke test")
    parser.add_argument("--policies", default="pibt", help="comma-separated: pibt,shortest,random")
    parser.add_argument("--skip-scale", action="store_true", help="only the throughput table")
    parser.add_argument("--json", type=Path, help="write the results to this JSON file")
    args = parser.parse_args(argv)
    policies = args.policies.split(",")
    for name in policies:
        if name not in ("pibt", "shortest", "random"):
            parser.error(f"unknown policy {name!r}")
    print(f"CPU time; Python {platform.python_version()}, {os.cpu_count()} CPUs", flush=True)
    if args.quick:
        table = throughput_table(policies, [16], [0], 16)
        scale = {} if args.skip_scale else scale_run(200, 3)
    else:
        table = throughput_table(policies, [128, 192], [0, 1, 2, 3, 4], 256)
        scale = {} if args.skip_scale else scale_run(10_000, 256)
    results = {
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "python": sys.version,
        "throughput": table,
        "published_kiva_192": PUBLISHED_KIVA_192,
        "scale": scale,
    }
    if args.json is not None:
        atomic_write_text(args.json, json.dumps(results, indent=2) + "\n")
        print(f"wrote {args.json}")
    return results


if __name__ == "__main__":
    main()
