"""Golden runs of the physics twin's bodies, recorded before the world was split into
regions stepped in parallel (issue 44), in lock step and on ticks, for both move models.

Each run records, after every step or tick, a SHA-256 digest of every body's pose (the
position of every robot after each physics step of a lock-step move, before the snap,
and its snap error; on ticks the robots' positions, and turning robots' angles, after
the tick, mid-move for most of them), and the raw poses after the last one, so a failing
test says at which step the bodies first left their recorded course.

``python -m tests.physics.golden_bodies`` rewrites ``tests/physics/golden_bodies.npz``;
``tests/physics/test_golden_bodies.py`` checks that the world still produces these runs
bit for bit, and with every number of threads. Regenerate only for an intended change of
behaviour, and say so in the commit.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import numpy as np

from warehouse_phys.envs import async_fleet, fleet
from warehouse_phys.execution.delays import DelayConfig

GOLDEN_FILE = Path(__file__).resolve().parent / "golden_bodies.npz"

#: Delays heavy enough that most robots stop mid-move at some point.
DELAYS = DelayConfig(seed=3, min_delay=1, max_delay=6, event_model="bernoulli",
                     p_delay=0.03, duration_model="uniform")  # fmt: skip

#: (name, keywords of the asynchronous fleet, ticks): the physics twin on ticks.
TICK_SCENARIOS = [
    ("ticks_grid", {"layout": "warehouse", "num_robots": 160, "ticks_per_move": 3}, 90),
    ("ticks_rotate", {"layout": "warehouse", "num_robots": 160, "ticks_per_move": 3,
                      "moves": "rotate"}, 90),
    ("ticks_grid_t10", {"layout": "warehouse", "num_robots": 120, "ticks_per_move": 10,
                        "track_gaps": True}, 60),
]  # fmt: skip
#: (name, keywords of the lock-step fleet, steps): random joint actions, bumps included.
LOCKSTEP_SCENARIOS = [
    ("lockstep_grid", {"layout": "warehouse", "num_robots": 150, "lifelong": True}, 40),
    ("lockstep_rotate", {"layout": "warehouse", "num_robots": 150, "lifelong": True,
                         "moves": "rotate"}, 40),
    ("lockstep_grid_untracked", {"layout": "warehouse", "num_robots": 150, "lifelong": True,
                                 "track_gaps": False}, 40),
]  # fmt: skip


def digest(*arrays: np.ndarray) -> np.ndarray:
    """The SHA-256 of the arrays' bytes (float64, C order), as 32 uint8."""
    sha = hashlib.sha256()
    for array in arrays:
        sha.update(np.ascontiguousarray(array, dtype=np.float64).tobytes())
    return np.frombuffer(sha.digest(), dtype=np.uint8)


def run_ticks(kwargs: dict[str, Any], ticks: int, **extra: Any) -> dict[str, np.ndarray]:
    """Every robot GO every tick under :data:`DELAYS`; the bodies after each tick."""
    env = async_fleet.parallel_env(physics=True, delays=DELAYS, max_cycles=ticks, seed=0,
                                   **kwargs, **extra)  # fmt: skip
    env.reset(seed=5)
    world = env.world
    go = dict.fromkeys(env.possible_agents, async_fleet.GO)
    digests, snaps = [], []
    while env.agents:
        _, _, _, _, infos = env.step(go)
        poses = [world.positions()] + ([world.orientations()] if env.turning else [])
        if kwargs.get("track_gaps", False):  # the paths recorded for closest_approach
            poses.append(world.last_paths)
        digests.append(digest(*poses))
        snaps.append([info["snap_error"] for info in infos.values()])
    final = world.orientations() if env.turning else np.zeros(0)
    return {"digests": np.array(digests), "snap_error": np.array(snaps),
            "positions": world.positions(), "orientations": final}  # fmt: skip


def run_lockstep(kwargs: dict[str, Any], steps: int, **extra: Any) -> dict[str, np.ndarray]:
    """Random joint actions (their own generator); each step's paths and snap errors."""
    env = fleet.parallel_env(physics=True, max_cycles=steps, **kwargs, **extra)
    env.reset(seed=9)
    world = env.world
    rng = np.random.default_rng(2024)
    digests, snaps = [], []
    while env.agents:
        actions = {agent: int(rng.integers(env.action_space(agent).n)) for agent in env.agents}
        _, _, _, _, infos = env.step(actions)
        snap = np.array([info["snap_error"] for info in infos.values()])
        poses = [snap, world.heading_errors]
        if kwargs.get("track_gaps", True):  # the paths recorded for min_gap
            poses.append(world.last_paths)
            if env.turning:
                poses.append(world.last_orientations)
        digests.append(digest(*poses))
        snaps.append(snap)
    return {"digests": np.array(digests), "snap_error": np.array(snaps),
            "cells": env.robot_cells.copy()}  # fmt: skip


def record_all() -> dict[str, np.ndarray]:
    arrays = {}
    for name, kwargs, ticks in TICK_SCENARIOS:
        for key, value in run_ticks(kwargs, ticks).items():
            arrays[f"{name}/{key}"] = value
    for name, kwargs, steps in LOCKSTEP_SCENARIOS:
        for key, value in run_lockstep(kwargs, steps).items():
            arrays[f"{name}/{key}"] = value
    return arrays


def golden(name: str) -> dict[str, np.ndarray]:
    """The recorded run ``name``."""
    with np.load(GOLDEN_FILE) as recorded:
        return {key.split("/", 1)[1]: recorded[key] for key in recorded.files
                if key.startswith(f"{name}/")}  # fmt: skip


if __name__ == "__main__":
    np.savez_compressed(GOLDEN_FILE, **record_all())
    print(f"wrote {GOLDEN_FILE}")
