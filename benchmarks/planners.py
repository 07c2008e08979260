"""Guided PIBT against plain PIBT: the LoRR 10,000-robot instance, the Kiva floor, scaling.

Three measurements, one core (numpy's threads held to one; a fleet's first guide paths
are searched on every core, :data:`~warehouse_phys.planners.guidance_config.FIRST_SEARCH_BATCH`),
CPU time (``time.process_time``, every thread's):

- **MR23-I-10** (League of Robot Runners 2023, 10,000 robots on warehouse_large, four
  directions; record 38.9 errands a step with turning robots, plain PIBT about 22): each
  planner in a fresh process, as ``benchmarks/lorr.py`` runs PIBT: errands finished a
  step (and over the last ``--window`` steps), refused moves, the first step (the first
  errands' distance maps and, guided, every robot's first guide path), the median and
  slowest later step, guide-path searches a step, robots the time limit left unguided,
  peak resident memory. ``--moves rotate``: turning robots (LoRR's own model).
  ``--instance PATH`` plays another LoRR instance instead (2024 ``WAREHOUSE.json``:
  its two-stop tasks through the built-in scheduler, counted as tasks a step too;
  ``--scheduler makespan`` weighs each task's own length, as the default entry does).
  Beside them, the instance's congestion-free flow
  (:mod:`warehouse_phys.lorr.task_flow`): what its errand list and scheduler would
  finish if robots never met, so a planner's figure says how much traffic took.
- **kiva-33-46** (POGEMA's lifelong setting: 256 steps, seeds 0-4) at 32 to 256 robots:
  deliveries a step, the mean over the seeds, the planners interleaved seed by seed on
  the same fleet; the median CPU time of a plan. Published at 128 robots: RHCR 3.49; at
  192: Follower 3.94 (POGEMA).
- **Scaling** (``--scaling``): 1,000 to 10,000 robots on warehouse_large
  (``warehouse-large-140-500.map``), lifelong with random packages, ``--scaling-steps``
  steps: errands a step over the run and over its last half, each planner against the
  congestion-free ceiling, robots divided by the mean shortest distance between
  consecutive errands (measured: from each delivered package to the robot's next one, over
  the runs' deliveries); ``--plot PATH`` draws it.

Planners are named as :data:`warehouse_phys.rl.fleet_planners.PLANNERS`: ``pibt``,
``guided`` (following congestion-priced guide paths), and the ablations
``guided-paths`` (following shortest guide paths) and ``guided-costs`` (PIBT's
distances with the guide paths' traffic as a tie-break).

    python benchmarks/planners.py [--steps 5000] [--planners pibt,guided]
        [--skip-lorr] [--skip-kiva] [--moves grid|rotate] [--instance PATH]
        [--scheduler nearest|makespan] [--time-limit S] [--guidance JSON]
        [--progress N] [--json PATH]
        [--scaling] [--scaling-steps 500] [--plot PATH] [--quick]
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

import numpy as np

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("MKL_NUM_THREADS", "1")

from warehouse_phys.envs import lorr
from warehouse_phys.envs.fleet import parallel_env
from warehouse_phys.files.atomic import atomic_write_text
from warehouse_phys.lorr.instances import read_instance
from warehouse_phys.lorr.scheduling_assignment import SCHEDULER_NAMES, scheduler_for
from warehouse_phys.lorr.task_flow import congestion_free_flow
from warehouse_phys.rl.fleet_planners import (
    PLANNER_OPERATIONS,
    PLANNER_REPAIRS,
    PLANNERS,
    planner_policy,
)

SHARED = Path(__file__).resolve().parents[2] / "shared"
MR23 = SHARED / "lorr" / "2023-main-warehouse" / "MR23-I-10.json"
#: ``--quick`` plays the 200-robot example instance on the same map instead.
EI23_200 = SHARED / "lorr" / "2023-examples-warehouse" / "EI23-warehouse_large_200.json"
KIVA = SHARED / "maps" / "kiva-33-46.map"
WAREHOUSE_LARGE = SHARED / "maps" / "warehouse-large-140-500.map"
#: Robots on warehouse_large in the scaling runs (``--quick``: a few).
SCALING_ROBOTS = (1000, 2000, 5000, 10000)
#: Robots on the Kiva floor.
KIVA_ROBOTS = (32, 64, 96, 128, 160, 192, 224, 256)
#: Published lifelong throughput on kiva-33-46 (256 steps) [deliveries/step], by robots.
PUBLISHED_KIVA = {128: {"RHCR": 3.49}, 192: {"Follower": 3.94, "RHCR": 1.57}}


#: Guidance settings of every guided run (``--guidance JSON``: GuidanceConfig's fields).
GUIDANCE: dict[str, object] = {}


def guidance_of(name: str, time_limit: float | None) -> dict[str, object]:
    if name == "pibt":
        return {}
    return GUIDANCE | ({} if time_limit is None else {"time_limit": time_limit})


def scheduler_name(text: str) -> str:
    """A scheduler's name: one of ``SCHEDULER_NAMES``, or ``assignment=W`` or ``rematch=W``
    (W >= 0)."""
    kind, equals, weight = text.partition("=")
    try:
        weighed = kind in ("assignment", "rematch") and equals and float(weight) >= 0
        if text in SCHEDULER_NAMES or weighed:
            return text
    except ValueError:
        pass
    raise argparse.ArgumentTypeError(
        f"expected one of {SCHEDULER_NAMES}, assignment=W or rematch=W"
    )


def scheduler_option(name: str | None, grid: object) -> dict[str, object]:
    """The fleet's ``scheduler=`` for a scheduler's name on ``grid`` (none: its default)."""
    return {} if name is None else {"scheduler": scheduler_for(name, grid)}


def lorr_run(
    name: str,
    steps: int,
    window: int,
    time_limit: float | None,
    instance: Path = MR23,
    moves: str = "grid",
    scheduler: str | None = None,
    progress: int = 0,
) -> dict[str, object]:
    """One planner on ``instance`` (MR23-I-10) in this process; its figures. ``scheduler``
    names a built-in scheduler for a 2024 instance (None: the fleet's default); every
    ``progress`` steps (0: never) the counts so far go to stderr."""
    loaded = read_instance(instance)
    env = lorr.fleet(loaded, moves=moves, max_cycles=steps,
                     **scheduler_option(scheduler, loaded.grid))  # fmt: skip
    policy = planner_policy(name, seed=0, **guidance_of(name, time_limit))
    gc.freeze()  # as simulate does: the floor's objects leave Python's full collections
    observations, infos = env.reset(seed=0)
    step_s, wall_s, refused, done_at, searches, unguided = [], [], 0, [], [], 0
    tasks_at = []
    for _ in range(steps):
        begun, begun_wall = time.process_time(), time.perf_counter()
        actions = policy(env, observations, infos)
        observations, _, _, _, infos = env.step(actions)
        step_s.append(time.process_time() - begun)
        wall_s.append(time.perf_counter() - begun_wall)
        tasks_at.append(env.errands.tasks_done)
        refused += sum(info["refused"] for info in infos.values())
        done_at.append(env.errands.errands_done)
        if progress and len(done_at) % progress == 0:
            print(f"{name} step {len(done_at)}: {done_at[-1] / len(done_at):.2f} errands/step, "
                  f"{env.errands.tasks_done / len(done_at):.2f} tasks/step, median "
                  f"{statistics.median(step_s[1:] or step_s) * 1000:.0f} ms/step",
                  file=sys.stderr, flush=True)  # fmt: skip
        guidance = getattr(getattr(policy, "planner", None), "guidance", None)
        if guidance is not None:  # a guided planner's
            searches.append(guidance.searches)
            unguided += guidance.timed_out
    later = step_s[1:] or step_s
    later_wall = wall_s[1:] or wall_s
    last = min(window, steps)
    third = steps // 3
    thirds = [tasks_at[third - 1], tasks_at[2 * third - 1], tasks_at[-1]] if third else [0, 0, 0]
    return {
        "planner": name,
        "instance": env.instance.name,
        "moves": moves,
        "scheduler": scheduler,
        "robots": env.num_robots,
        "steps": steps,
        "errands_per_step": env.errands.errands_done / steps,
        "tasks_per_step": env.errands.tasks_done / steps,
        "errands_per_step_last": (done_at[-1] - (done_at[-last - 1] if last < steps else 0)) / last,
        "last_steps": last,
        "refused": refused,
        "first_step_s": step_s[0],
        "step_s_median": statistics.median(later),
        "step_s_max": max(later),
        "first_step_wall_s": wall_s[0],
        "step_wall_s_median": statistics.median(later_wall),
        "step_wall_s_max": max(later_wall),
        "tasks_per_step_thirds": [
            thirds[0] / max(third, 1),
            (thirds[1] - thirds[0]) / max(third, 1),
            (thirds[2] - thirds[1]) / max(steps - 2 * third, 1),
        ],
        "tasks_at": tasks_at[99::100],
        "first_step_searches": searches[0] if searches else None,
        "searches_per_step": statistics.fmean(searches[1:] or searches) if searches else None,
        "unguided": unguided,
        "peak_rss_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
    }


def flow_run(instance: Path, steps: int, scheduler: str | None) -> dict[str, object]:
    """The congestion-free flow of ``instance`` (:mod:`warehouse_phys.lorr.task_flow`):
    what its errand list and scheduler would finish if robots never met."""
    loaded = read_instance(instance)
    flow = congestion_free_flow(loaded, steps, **scheduler_option(scheduler, loaded.grid))
    return {
        "instance": loaded.name,
        "scheduler": scheduler,
        "steps": steps,
        "errands_per_step": flow.errands_per_step,
        "tasks_per_step": flow.tasks_per_step,
    }


def describe_lorr(run: dict[str, object]) -> str:
    searches = run["searches_per_step"]
    guided = "" if searches is None else (
        f", {searches:.0f} searches/step, {run['unguided']} robot-steps left unguided")  # fmt: skip
    return (
        f"{run['instance']} {run.get('moves', 'grid')} {run['robots']:>6,} robots "
        + (f"(scheduler {run['scheduler']}) " if run.get("scheduler") else "")
        + f"{run['planner']:<13} "
        f"{run['steps']:>5} steps: "
        f"{run['errands_per_step']:6.2f} errands/step ({run['errands_per_step_last']:.2f} over "
        f"the last {run['last_steps']}), {run.get('tasks_per_step', 0):.2f} tasks/step, "
        f"{run['refused']} refused; first step "
        f"{run['first_step_s']:.1f} s, then {run['step_s_median'] * 1000:.0f} ms/step (max "
        f"{run['step_s_max'] * 1000:.0f}) CPU, {run.get('step_wall_s_median', 0) * 1000:.0f} ms "
        f"(max {run.get('step_wall_s_max', 0) * 1000:.0f}, first "
        f"{run.get('first_step_wall_s', 0):.1f} s) wall{guided}; peak "
        f"{run['peak_rss_mib']:,.0f} MiB"
    )


def kiva_table(
    planners: list[str],
    robots: tuple[int, ...],
    seeds: range,
    steps: int,
    time_limit: float | None,
    moves: str = "grid",
) -> list[dict[str, object]]:
    """Lifelong throughput on kiva-33-46, the planners interleaved seed by seed; turning
    robots with ``moves="rotate"`` (the published figures are for four directions)."""
    rows = []
    for n in robots:
        env = parallel_env(num_robots=n, layout=str(KIVA), on_delivery="new_package",
                           max_cycles=steps, moves=moves)  # fmt: skip
        found = {name: {"per_seed": [], "plan_s": [], "refused": 0} for name in planners}
        for seed in seeds:
            for name in planners:
                policy = planner_policy(name, seed=seed, **guidance_of(name, time_limit))
                observations, infos = env.reset(seed=seed)
                delivered = 0
                for _ in range(steps):
                    begun = time.process_time()
                    actions = policy(env, observations, infos)
                    found[name]["plan_s"].append(time.process_time() - begun)
                    observations, rewards, _, _, infos = env.step(actions)
                    delivered += int(sum(rewards.values()))
                    found[name]["refused"] += sum(info["refused"] for info in infos.values())
                found[name]["per_seed"].append(delivered / steps)
        for name in planners:
            values = found[name]["per_seed"]
            plan_ms = 1000 * statistics.median(found[name]["plan_s"])
            rows.append({"robots": n, "planner": name, "throughput": statistics.fmean(values),
                         "per_seed": values, "refused": found[name]["refused"],
                         "plan_ms_median": plan_ms})  # fmt: skip
            row = rows[-1]
            row["moves"] = moves
            published = "; ".join(f"{k} {v}" for k, v in PUBLISHED_KIVA.get(n, {}).items())
            if moves != "grid":
                published = ""  # published for four directions only
            print(
                f"kiva-33-46 {n:>4} robots {name:<13} {row['throughput']:5.2f} deliveries/step "
                f"(seeds {min(values):.2f}-{max(values):.2f}), {row['refused']} refused, plan "
                f"{row['plan_ms_median']:.1f} ms{'; published: ' + published if published else ''}",
                flush=True,
            )
    return rows


def scaling_run(
    name: str, robots: int, steps: int, time_limit: float | None, layout: Path = WAREHOUSE_LARGE
) -> dict[str, object]:
    """One planner, ``robots`` robots on ``layout``, lifelong with random packages, seed 0:
    errands a step (the run, its last half) and the lengths of the errands handed out
    (shortest distance from each delivered package to the robot's next package)."""
    env = parallel_env(layout=str(layout), num_robots=robots, lifelong=True, max_cycles=steps)
    policy = planner_policy(name, seed=0, **guidance_of(name, time_limit))
    observations, infos = env.reset(seed=0)
    cols, done_at, legs, refused, step_s = env.grid.cols, [], [], 0, []
    for _ in range(steps):
        before = env.package_cells.copy()
        begun = time.process_time()
        actions = policy(env, observations, infos)
        step_s.append(time.process_time() - begun)
        observations, _, _, _, infos = env.step(actions)
        refused += sum(info["refused"] for info in infos.values())
        done_at.append(int(env.deliveries.sum()))
        after = env.package_cells
        new = (before != after).any(axis=1)
        if new.any():
            old_cells, new_cells = before[new], after[new]
            legs.append(env.distances.lookup(old_cells[:, 0] * cols + old_cells[:, 1],
                                             new_cells[:, 0] * cols + new_cells[:, 1]))  # fmt: skip
    half = steps - steps // 2
    legs_all = np.concatenate(legs) if legs else np.zeros(0, np.int64)
    return {
        "planner": name,
        "robots": robots,
        "steps": steps,
        "errands_per_step": done_at[-1] / steps,
        "errands_per_step_last_half": (done_at[-1] - (done_at[-half - 1] if half < steps else 0))
        / half,
        "refused": refused,
        "step_s_median": statistics.median(step_s[1:] or step_s),
        "legs": int(legs_all.size),
        "leg_sum": int(legs_all.sum()),
    }


def scaling_table(
    planners: list[str],
    robots: tuple[int, ...],
    steps: int,
    time_limit: float | None,
    layout: Path = WAREHOUSE_LARGE,
) -> dict[str, object]:
    """The planners at each fleet size on ``layout``, and the congestion-free ceiling."""
    rows = []
    for n in robots:
        found = [scaling_run(name, n, steps, time_limit, layout) for name in planners]
        legs = sum(run["legs"] for run in found)
        mean_leg = sum(run["leg_sum"] for run in found) / legs if legs else None
        for run in found:
            run["ceiling"] = n / mean_leg if mean_leg else None
            run["mean_errand_distance"] = mean_leg
            rows.append(run)
            print(
                f"{layout.stem} {n:>6,} robots {run['planner']:<13} {steps} steps: "
                f"{run['errands_per_step']:6.2f} errands/step "
                f"({run['errands_per_step_last_half']:.2f} over the last half), "
                f"{run['refused']} refused, {run['step_s_median'] * 1000:.0f} ms/step; "
                + (
                    f"ceiling {run['ceiling']:.2f} (mean errand {mean_leg:.1f} moves, "
                    f"{legs} errands)"
                    if mean_leg
                    else "no errand handed out: no ceiling"
                ),
                flush=True,
            )
    return {"layout": layout.name, "steps": steps, "rows": rows}


def scaling_plot(scaling: dict[str, object], path: Path) -> None:
    """Errands a step against robots, each planner and the ceiling; PNG at ``path``
    (:func:`warehouse_phys.viz.plots.planner_scaling_figure`)."""
    from warehouse_phys.viz.figures import save_figure
    from warehouse_phys.viz.throughput_figures import planner_scaling_figure

    save_figure(planner_scaling_figure(scaling), path)


def main(argv: list[str] | None = None) -> dict[str, object]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=5000, help="MR23-I-10 steps (5000)")
    parser.add_argument("--window", type=int, default=1000, help="steps of the 'last' rate")
    parser.add_argument("--planners", default="pibt,guided", help=f"of {','.join(PLANNERS)}")
    parser.add_argument("--time-limit", type=float, help="the guidance's seconds a step")
    parser.add_argument("--skip-lorr", action="store_true", help="no MR23-I-10 runs")
    parser.add_argument("--instance", type=Path, default=MR23,
                        help="the LoRR instance of those runs (MR23-I-10)")  # fmt: skip
    parser.add_argument("--scheduler", type=scheduler_name,
                        help="a 2024 instance's scheduler (the fleet's default)")  # fmt: skip
    parser.add_argument("--skip-kiva", action="store_true", help="no kiva-33-46 table")
    parser.add_argument("--quick", action="store_true", help="tiny budgets: a smoke test")
    parser.add_argument("--moves", default="grid", choices=("grid", "rotate"),
                        help="the move model of MR23-I-10 and the Kiva floor (grid)")  # fmt: skip
    parser.add_argument("--scaling", action="store_true", help="warehouse_large, 1k-10k robots")
    parser.add_argument("--scaling-steps", type=int, default=500, help="steps a scaling run")
    # A smaller floor for smoke runs (the tests'): a short scaling run's time goes to the
    # floor's tables, and warehouse_large has 46 times kiva-33-46's cells.
    parser.add_argument("--scaling-map", type=Path, default=WAREHOUSE_LARGE,
                        help=argparse.SUPPRESS)  # fmt: skip
    parser.add_argument("--plot", type=Path, help="draw the scaling runs to this PNG")
    parser.add_argument("--json", type=Path, help="write the results to this JSON file")
    parser.add_argument("--progress", type=int, default=0,
                        help="LoRR runs: counts so far every N steps (0: none)")  # fmt: skip
    parser.add_argument("--guidance", type=json.loads, default={},
                        help="guided runs' GuidanceConfig fields, as JSON")  # fmt: skip
    parser.add_argument("--one", help=argparse.SUPPRESS)  # an MR23-I-10 run in a fresh process
    args = parser.parse_args(argv)
    planners = args.planners.split(",")
    unknown = [name for name in planners if name not in PLANNERS]
    if unknown:
        parser.error(f"unknown planners {unknown}; known: {list(PLANNERS)}")
    turning_only = [name for name in planners if name in {**PLANNER_OPERATIONS, **PLANNER_REPAIRS}]
    if turning_only and (args.moves != "rotate" or args.scaling):
        parser.error(f"{turning_only} plan turning robots: add --moves rotate (the scaling "
                     "runs are four-direction)")  # fmt: skip
    steps = 3 if args.quick else args.steps
    if args.quick:
        args.instance = EI23_200
    GUIDANCE.clear()
    GUIDANCE.update(args.guidance)
    if args.one is not None:
        run = lorr_run(args.one, steps, args.window, args.time_limit, args.instance, args.moves,
                       args.scheduler, args.progress)  # fmt: skip
        print(json.dumps(run))
        return {}
    print(f"CPU time, one core (the first step's guide searches on every core); Python "
          f"{platform.python_version()}, {os.cpu_count()} CPUs",
          flush=True)  # fmt: skip
    runs, flow = [], None
    if not args.skip_lorr and not args.instance.exists():
        print(f"{args.instance.stem}: skipped, {args.instance} is absent")
    elif not args.skip_lorr:
        for name in planners:
            command = [sys.executable, __file__, "--one", name, "--steps", str(steps),
                       "--window", str(args.window), "--moves", args.moves,
                       "--instance", str(args.instance)]  # fmt: skip
            command += ["--quick"] if args.quick else []
            command += [] if args.scheduler is None else ["--scheduler", args.scheduler]
            command += ["--progress", str(args.progress)] if args.progress else []
            command += ["--guidance", json.dumps(args.guidance)] if args.guidance else []
            if args.time_limit is not None:
                command += ["--time-limit", str(args.time_limit)]
            # With progress, the run's stderr (its progress, or its error) goes straight on.
            done = subprocess.run(command, stdout=subprocess.PIPE, text=True, check=False,
                                  stderr=None if args.progress else subprocess.PIPE)  # fmt: skip
            if done.returncode != 0:
                last = (done.stderr or "").strip().splitlines()[-1:]
                print(f"{args.instance.stem} {name}: failed (exit {done.returncode}) {last}")
                continue
            runs.append(json.loads(done.stdout.strip().splitlines()[-1]))
            print(describe_lorr(runs[-1]), flush=True)
        flow = flow_run(args.instance, steps, args.scheduler)
        print(f"{flow['instance']} congestion-free flow (robots that never meet, Manhattan "
              f"paths, no turns), {steps} steps: {flow['errands_per_step']:.2f} errands/step, "
              f"{flow['tasks_per_step']:.2f} tasks/step", flush=True)  # fmt: skip
    table = []
    if not args.skip_kiva and not KIVA.exists():
        print(f"kiva-33-46: skipped, {KIVA} is absent")
    elif not args.skip_kiva:
        robots, seeds, horizon = ((32, 64), range(1), 16) if args.quick else (
            KIVA_ROBOTS, range(5), 256)  # fmt: skip
        table = kiva_table(planners, robots, seeds, horizon, args.time_limit, args.moves)
    scaling = None
    if args.scaling and not args.scaling_map.exists():
        print(f"scaling: skipped, {args.scaling_map} is absent")
    elif args.scaling:
        robots, horizon = ((100, 200), 4) if args.quick else (SCALING_ROBOTS, args.scaling_steps)
        scaling = scaling_table(planners, robots, horizon, args.time_limit, args.scaling_map)
        if args.plot is not None:
            scaling_plot(scaling, args.plot)
            print(f"wrote {args.plot}")
    summary = {"created": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "python": sys.version,
               "guidance": args.guidance,
               "timer": "time.process_time", "mr23": runs, "flow": flow, "kiva": table,
               "published_kiva": PUBLISHED_KIVA, "scaling": scaling}  # fmt: skip
    if args.json is not None:
        atomic_write_text(args.json, json.dumps(summary, indent=2) + "\n")
        print(f"wrote {args.json}")
    return summary


if __name__ == "__main__":
    main()
