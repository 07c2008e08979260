"""Big floors at full fleet size: the field's maps with 10,000 robots, beside a numpy reference.

Each map runs in a fresh process on one core (numpy's threads held to one): a lifelong
fleet (``on_delivery="new_package"``) of 10,000 robots planned by PIBT
(:func:`warehouse_phys.planners.pibt.pibt_policy`), as ``simulate`` runs it. Measured in
CPU time (``time.process_time``):

- ours alone for ``--steps`` steps: the floor's build, the reset (the first packages'
  distances), the first step and the later steps (median, slowest), deliveries a step,
  the distance maps kept and the goals guided by paths
  (:class:`warehouse_phys.planners.distances.DistanceMaps`), the process's peak resident
  memory up to then;
- then **the reference**, a plain numpy implementation in the same process:
  - *first step*: the distance maps of every robot's first package by a batched
    breadth-first search, one array operation per level over a batch of goals (the way
    to do it without compiled code). Where all of them would take more than a minute,
    a sample of goals is timed and scaled to all (said in the output);
  - *later step*: for another ``--steps`` steps, on the fleet's own state, a plain PIBT
    (Okumura's algorithm as pypibt writes it: occupancy arrays, one recursion,
    candidates sorted by distance with a seeded random tie-break), over full distance
    maps from the same numpy search kept in a dictionary (new goals searched each
    step), and its moves applied; timed step by step, interleaved with ours. Only where
    its maps fit in :data:`REFERENCE_MAPS_BYTES`.

Compiled kernels (Numba) are loaded before the clock starts. Maps: the MovingAI maps in
``--maps`` (default ``../shared/maps``) among :data:`MAPS`, and a generated 2,048 x 2,048
floor with 10 % random obstacles (seed 0; ``--side`` another size). The field's big maps
are in the League of Robot Runners' start kit (``example_problems/*/maps``); point
``--maps`` at a folder holding them. Missing maps are listed as such.

    python benchmarks/big_maps.py [--maps DIR] [--robots 10000] [--steps 32] [--side 2048]
        [--distance-mib MIB] [--only NAME[,NAME]] [--json PATH] [--quick]
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
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np

from warehouse_phys.envs.fleet import parallel_env
from warehouse_phys.files.atomic import atomic_write_text
from warehouse_phys.planners.distances import DistanceMaps
from warehouse_phys.planners.graph_search import move_graph
from warehouse_phys.rl.fleet_planners import pibt_policy
from warehouse_phys.world.layouts import make_grid
from warehouse_phys.world.maps import random_floor

SHARED_MAPS = Path(__file__).resolve().parents[2] / "shared" / "maps"
#: The maps run, by file stem: the issue's list (the field's big maps) and ours.
MAPS = (
    "warehouse-large-140-500",
    "sortation_large",
    "Boston_0_256",
    "Paris_1_256",
    "brc202d",
    "orz900d",
    "scene_mp_2p_01",
)
#: ``--quick``: a smoke run (few robots and steps, a 256-cell-square generated floor,
#: distance maps for few goals so that the rest are guided: 17 of 40 on the generated
#: floor, 27 on warehouse_large). The reference's searches cost in proportion to the goals.
QUICK = {"robots": 40, "steps": 3, "side": 256, "distance_mib": 2}
#: The reference's first step is timed on a sample of goals when all would take longer
#: than this [s].
REFERENCE_BUDGET_S = 60.0
#: Memory for one batch of the reference's search [bytes].
REFERENCE_BATCH_BYTES = 256 * 2**20
#: Most memory the reference's later steps may keep in full maps [bytes]; beyond it (the
#: biggest floors, whose 10,000 maps would take tens of GB) it has no later step.
REFERENCE_MAPS_BYTES = 3 * 2**30


def numpy_distance_maps(neighbours: np.ndarray, sources: np.ndarray) -> np.ndarray:
    """The reference's search: moves from every free cell to each of ``sources`` (free-cell
    columns), ``(len(sources), n)`` int32, -1 where unreachable; one numpy pass per level
    over all the sources at once."""
    n = len(neighbours)
    count = len(sources)
    distance = np.full((count, n), -1, dtype=np.int32)
    mark = np.empty((count, n), dtype=np.int32)
    owner, frontier = np.arange(count), np.asarray(sources, dtype=np.int64)
    distance[owner, frontier] = 0
    level = 0
    while frontier.size:
        level += 1
        owner = np.repeat(owner, 4)
        reached = neighbours[frontier].reshape(-1).astype(np.int64)
        keep = reached >= 0
        owner, reached = owner[keep], reached[keep]
        keep = distance[owner, reached] < 0
        owner, reached = owner[keep], reached[keep]
        distance[owner, reached] = level
        # One entry per cell reached: the last write of a position wins, the rest go.
        mark[owner, reached] = np.arange(len(owner), dtype=np.int32)
        first = mark[owner, reached] == np.arange(len(owner))
        owner, frontier = owner[first], reached[first]
    return distance


class ReferencePIBT:
    """A plain PIBT, as pypibt writes it, over the reference's own distance maps."""

    NIL = -1

    def __init__(self, neighbours: np.ndarray, seed: int = 0) -> None:
        self.neighbours = neighbours
        self.rng = np.random.default_rng(seed)
        self.maps: dict[int, np.ndarray] = {}
        self.priority: np.ndarray | None = None

    def step(self, here: np.ndarray, goal: np.ndarray) -> np.ndarray:
        """Every robot's next cell (columns), and the search of goals new this step."""
        new = [g for g in np.unique(goal).tolist() if g not in self.maps]
        per_batch = max(1, REFERENCE_BATCH_BYTES // (8 * len(self.neighbours)))
        for start in range(0, len(new), per_batch):
            batch = new[start : start + per_batch]
            rows = numpy_distance_maps(self.neighbours, np.array(batch))
            for g, row in zip(batch, rows, strict=True):
                self.maps[g] = row
        live = set(goal.tolist())
        for g in [g for g in self.maps if g not in live]:
            del self.maps[g]
        n = len(here)
        if self.priority is None or len(self.priority) != n:
            self.priority = self.rng.random(n) / n
        at_goal = here == goal
        self.priority[at_goal] -= np.floor(self.priority[at_goal])
        self.priority[~at_goal] += 1
        self.here, self.dist = here.tolist(), [self.maps[g] for g in goal.tolist()]
        self.now = np.full(len(self.neighbours), self.NIL, dtype=np.int64)
        self.now[here] = np.arange(n)
        self.next = np.full(len(self.neighbours), self.NIL, dtype=np.int64)
        self.plan = [self.NIL] * n
        for i in np.argsort(-self.priority, kind="stable").tolist():
            if self.plan[i] == self.NIL:
                self._pibt(i)
        return np.array(self.plan)

    def _pibt(self, i: int) -> bool:
        here = self.here[i]
        candidates = [here] + [c for c in self.neighbours[here].tolist() if c >= 0]
        self.rng.shuffle(candidates)
        candidates.sort(key=self.dist[i].__getitem__)
        for v in candidates:
            if self.next[v] != self.NIL:
                continue
            j = int(self.now[v])
            if j != self.NIL and self.plan[j] == here:
                continue  # a swap
            self.plan[i] = v
            self.next[v] = i
            if j not in (self.NIL, i) and self.plan[j] == self.NIL and not self._pibt(j):
                continue
            return True
        self.plan[i] = here
        self.next[here] = i
        return False


def generated_floor(path: Path, side: int = 2048, density: float = 0.1) -> Path:
    """The package's random floor (:func:`~warehouse_phys.world.maps.random_floor`, seed 0)
    of ``side`` x ``side`` cells, ``density`` of them obstacles, as a MovingAI map."""
    rows = [row.replace("#", "@") for row in random_floor(side, side, density)]
    text = f"type octile\nheight {side}\nwidth {side}\nmap\n" + "\n".join(rows) + "\n"
    atomic_write_text(path, text)
    return path


def _warm_up() -> None:
    """Load the compiled kernels (Numba's disk cache) before any clock starts: a map, and
    a guided goal beyond the room of one map."""
    grid = make_grid(None, None, "aisles")
    maps = DistanceMaps(grid, max_bytes=DistanceMaps(grid)._map_bytes)
    free = np.flatnonzero(maps._column < maps._n_free)
    maps.lookup(free[:2], free[-2:])


def run_one(
    path: Path, robots: int, steps: int, distance_mib: float | None = None
) -> dict[str, object]:
    """One map in this process (see the module); its figures. ``distance_mib`` bounds
    the fleet's distance maps (default: ``distances.DEFAULT_MAX_BYTES``)."""
    _warm_up()
    begun = time.process_time()
    env = parallel_env(layout=str(path), num_robots=robots, max_cycles=2 * steps,
                       on_delivery="new_package")  # fmt: skip
    if distance_mib is not None:
        env.distances = DistanceMaps(env.grid, max_bytes=int(distance_mib * 2**20))
    build_s = time.process_time() - begun
    policy = pibt_policy(seed=0)
    gc.freeze()  # as simulate does: the floor's objects leave Python's full collections
    begun = time.process_time()
    observations, infos = env.reset(seed=0)
    reset_s = time.process_time() - begun
    free = np.ones((env.grid.rows, env.grid.cols), dtype=bool)
    maps = env.distances
    free.reshape(-1)[maps._column == maps._n_free] = False
    neighbours = move_graph(free)
    column = maps._column
    cols = env.grid.cols

    def columns(cells: np.ndarray) -> np.ndarray:
        return column[cells[:, 0] * cols + cells[:, 1]].astype(np.int64)

    first_goals = np.unique(columns(env.package_cells))
    # Ours alone first: its steps and its peak memory.
    ours_s, delivered = [], 0

    def step() -> None:
        nonlocal observations, infos, delivered
        begun = time.process_time()
        actions = policy(env, observations, infos)
        observations, _, _, _, infos = env.step(actions)
        ours_s.append(time.process_time() - begun)
        delivered += sum(info["deliveries"] for info in infos.values())

    for _ in range(steps):
        step()
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    # Then the reference: its first step on the same goals, and later steps interleaved
    # with ours on the fleet's state where its full maps fit.
    reference_first_s, sampled = _reference_first_step(neighbours, first_goals)
    reference = None
    if 4 * len(neighbours) * len(first_goals) <= REFERENCE_MAPS_BYTES:
        reference = ReferencePIBT(neighbours)
        reference.step(columns(env.robot_cells), columns(env.package_cells))  # its first maps
    side_by_side, reference_s = [], []
    for _ in range(steps if reference is not None else 0):
        begun = time.process_time()
        reference.step(columns(env.robot_cells), columns(env.package_cells))
        reference_s.append(time.process_time() - begun)
        step()
        side_by_side.append(ours_s[-1])
    later = ours_s[1:steps] or ours_s
    ratio = (
        statistics.median(side_by_side) / statistics.median(reference_s) if reference_s else None
    )
    return {
        "map": path.stem,
        "size": [env.grid.rows, env.grid.cols],
        "free_cells": int(maps._n_free),
        "robots": robots,
        "steps": steps,
        "build_s": build_s,
        "reset_s": reset_s,
        "first_step_s": ours_s[0],
        "reset_and_first_step_s": reset_s + ours_s[0],
        "step_s_median": statistics.median(later),
        "step_s_max": max(later),
        "reference_first_step_s": reference_first_s,
        "reference_first_step_sampled": sampled,
        "reference_step_s_median": statistics.median(reference_s) if reference_s else None,
        "side_by_side_step_s_median": statistics.median(side_by_side) if side_by_side else None,
        "first_step_ratio": (reset_s + ours_s[0]) / reference_first_s,
        "later_step_ratio": ratio,
        "deliveries_per_step": delivered / len(ours_s),
        "full_maps": maps.maps,
        "guided_goals": maps.guided,
        "map_mib": maps.nbytes / 2**20,
        "path_mib": maps.path_bytes / 2**20,
        "peak_rss_mib": peak,
    }


def _reference_first_step(neighbours: np.ndarray, goals: np.ndarray) -> tuple[float, bool]:
    """The reference's CPU time for the maps of ``goals``, and whether it was scaled up
    from a sample (the whole would take more than :data:`REFERENCE_BUDGET_S`)."""
    per_batch = max(1, REFERENCE_BATCH_BYTES // (8 * len(neighbours)))
    spent, done = 0.0, 0
    for start in range(0, len(goals), per_batch):
        batch = goals[start : start + per_batch]
        begun = time.process_time()
        numpy_distance_maps(neighbours, batch)
        spent += time.process_time() - begun
        done += len(batch)
        if spent > REFERENCE_BUDGET_S / 4 and done < len(goals):
            return spent * len(goals) / done, True
    return spent, False


def describe(result: dict[str, object]) -> str:
    r = result
    sampled = " scaled from a sample" if r["reference_first_step_sampled"] else ""
    later = (
        f"reference {r['reference_step_s_median'] * 1000:.0f} ms beside our "
        f"{r['side_by_side_step_s_median'] * 1000:.0f} ms, {r['later_step_ratio']:.2f}x"
        if r["later_step_ratio"] is not None
        else "no reference: its full maps would not fit"
    )
    return (
        f"{r['map']:<24} {r['size'][0]}x{r['size'][1]} {r['robots']:,} robots: reset + first "
        f"step {r['reset_and_first_step_s']:.1f} s (reference {r['reference_first_step_s']:.1f}"
        f" s{sampled}, {r['first_step_ratio']:.2f}x); later steps "
        f"{r['step_s_median'] * 1000:.0f} ms, max {r['step_s_max'] * 1000:.0f} ({later}); "
        f"{r['deliveries_per_step']:.1f} deliveries/step; {r['full_maps']:,} maps "
        f"({r['map_mib']:.0f} MiB), {r['guided_goals']:,} guided ({r['path_mib']:.1f} MiB); "
        f"peak {r['peak_rss_mib']:,.0f} MiB"
    )


def main(argv: list[str] | None = None) -> list[dict[str, object]]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--maps", type=Path, default=SHARED_MAPS)
    parser.add_argument("--robots", type=int, default=10_000)
    parser.add_argument("--steps", type=int, default=32)
    parser.add_argument("--side", type=int, default=2048, help="the generated floor's side")
    parser.add_argument("--distance-mib", type=float, default=None,
                        help="bound the fleet's distance maps [MiB]")  # fmt: skip
    parser.add_argument("--only", default="", help="comma-separated map names")
    parser.add_argument("--quick", action="store_true", help="a smoke run: " + str(QUICK))
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--one", type=Path, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.quick:
        for name, value in QUICK.items():
            setattr(args, name, value)
    if args.one is not None:  # the child: one map, its figures as JSON on stdout
        print(json.dumps(run_one(args.one, args.robots, args.steps, args.distance_mib)))
        return []
    generated = f"random-{args.side}-{args.side}-10"
    wanted = [name for name in args.only.split(",") if name] or [*MAPS, generated]
    results = []
    with tempfile.TemporaryDirectory() as folder:
        for name in wanted:
            if name == generated:
                path = generated_floor(Path(folder) / f"{generated}.map", args.side)
            else:
                path = args.maps / f"{name}.map"
                if not path.exists():
                    print(f"{name:<24} absent from {args.maps}", flush=True)
                    continue
            command = [sys.executable, __file__, "--one", str(path), "--robots",
                       str(args.robots), "--steps", str(args.steps)]  # fmt: skip
            if args.distance_mib is not None:
                command += ["--distance-mib", str(args.distance_mib)]
            child = subprocess.run(command, capture_output=True, text=True, check=False)
            if child.returncode:
                print(f"{name:<24} failed: {child.stderr.strip().splitlines()[-1:]}", flush=True)
                continue
            results.append(json.loads(child.stdout.strip().splitlines()[-1]))
            print(describe(results[-1]), flush=True)
    if args.json is not None:
        report = {"machine": platform.platform(), "python": sys.version.split()[0],
                  "results": results}  # fmt: skip
        atomic_write_text(args.json, json.dumps(report, indent=2) + "\n")
    return results


if __name__ == "__main__":
    main()
