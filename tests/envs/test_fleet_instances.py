"""Fleets of League of Robot Runners instances: starts and errands as the instance says,
PettingZoo's suites, determinism across processes, the physics twin (their refusals:
``test_fleet_setup.py``)."""

import functools
import hashlib
from pathlib import Path

import numpy as np
import pytest

from tests.envs.test_fleet import pettingzoo_quietly
from warehouse_phys.envs import fleet, lorr
from warehouse_phys.lorr.errands import NO_ERRAND
from warehouse_phys.lorr.instances import LorrInstance, write_instance
from warehouse_phys.rl.fleet_planners import pibt_policy
from warehouse_phys.world.grid import WarehouseGrid

with __import__("warnings").catch_warnings():
    __import__("warnings").simplefilter("ignore", DeprecationWarning)
    from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test, seed_test

LORR = Path(__file__).resolve().parents[3] / "shared" / "lorr"
FLOOR = WarehouseGrid.from_layout(["..........", ".##.##.##.", "..........",
                                   ".##.##.##.", ".........."])  # fmt: skip


def small_instance(assignment: str = "roundrobin", robots: int = 5, tasks: int = 40):
    """Robots along the top row, tasks of 1 (2023) or 2 (2024) stops on free cells."""
    rng = np.random.default_rng(7)
    free = [r * 10 + c for r in range(5) for c in range(10) if (r, c) not in FLOOR.shelves]
    stops = 1 if assignment != "scheduler" else 2
    return LorrInstance(
        name=f"small-{assignment}", grid=FLOOR, starts=list(range(robots)),
        task_offsets=np.arange(tasks + 1) * stops,
        task_stops=rng.choice(free, size=tasks * stops).tolist(), num_tasks_reveal=1.5,
        assignment=assignment, version="2024 LoRR" if assignment == "scheduler" else None,
    )  # fmt: skip


@pytest.mark.parametrize("moves", ["grid", "rotate"])
@pytest.mark.parametrize("assignment", ["roundrobin", "greedy", "scheduler"])
def test_the_fleet_starts_where_the_instance_says_and_counts_its_errands(assignment, moves):
    instance = small_instance(assignment)
    env = fleet.parallel_env(instance=instance, moves=moves)
    assert env.num_robots == 5
    assert env.max_cycles == fleet.LORR_STEPS
    obs, infos = env.reset(seed=3)
    assert (env.robot_cells @ [10, 1]).tolist() == [0, 1, 2, 3, 4]
    errands = env.errands
    policy = pibt_policy(0)
    total = 0
    for _ in range(60):
        before = errands.errands_done
        obs, rewards, terms, _truncs, infos = env.step(policy(env, obs, infos))
        assert sum(rewards.values()) == errands.errands_done - before
        total += sum(rewards.values())
        goals = errands.goals
        cells = env.package_cells @ [10, 1]
        assert np.array_equal(cells, np.where(goals != NO_ERRAND, goals, env.robot_cells @ [10, 1]))
        assert not any(terms.values())
        assert not any(info["refused"] for info in infos.values())
    assert total == env.deliveries.sum() == errands.errands_done > 5
    assert sum(info["tasks"] for info in infos.values()) == errands.tasks_done
    if assignment == "scheduler":
        assert errands.errands_done >= 2 * errands.tasks_done


@pytest.mark.parametrize("moves", ["grid", "rotate"])
def test_pettingzoos_suites_pass_for_instance_fleets(moves):
    kwargs = {"instance": small_instance("scheduler"), "moves": moves, "max_cycles": 50}
    pettingzoo_quietly(parallel_api_test, fleet.parallel_env(**kwargs), num_cycles=60)
    pettingzoo_quietly(parallel_seed_test, functools.partial(fleet.parallel_env, **kwargs), 40)
    pettingzoo_quietly(api_test, fleet.env(**kwargs), num_cycles=40)
    pettingzoo_quietly(seed_test, functools.partial(fleet.env, **kwargs), 20)


def run_digest(path: str, moves: str, steps: int) -> str:
    """A digest of every robot's cell and heading, and the errands, over a planned run."""
    env = lorr.fleet(path, moves=moves)
    obs, infos = env.reset(seed=0)
    policy, digest = pibt_policy(0), hashlib.sha256()
    for _ in range(steps):
        obs, _, _, _, infos = env.step(policy(env, obs, infos))
        digest.update(env.robot_cells.tobytes())
        digest.update(np.zeros(1) if env.robot_headings is None else env.robot_headings.tobytes())
    digest.update(env.errands.errands_per_robot.tobytes())
    return digest.hexdigest()


def test_an_instance_fleet_is_bit_identical_across_processes(tmp_path, run_python):
    """Both move models, in one fresh process (one interpreter to start, not two), in the
    other order there, so that neither case follows the other on both sides."""
    path = write_instance(small_instance("scheduler", robots=8), tmp_path / "small.json")
    script = (
        "from tests.envs.test_fleet_instances import run_digest\n"
        f"for moves in ('rotate', 'grid'): print(run_digest({str(path)!r}, moves, 80))"
    )
    here = {moves: run_digest(str(path), moves, 80) for moves in ("grid", "rotate")}
    assert run_python(script).split() == [here["rotate"], here["grid"]]


def test_the_physics_twin_of_an_instance_fleet_follows_the_grid_twin():
    instance = small_instance("greedy", robots=8, tasks=20)
    for moves in ("grid", "rotate"):
        grid = fleet.parallel_env(instance=instance, moves=moves, max_cycles=60)
        phys = fleet.parallel_env(instance=instance, moves=moves, max_cycles=60, physics=True)
        g_obs, g_infos = grid.reset(seed=0)
        phys.reset(seed=0)
        plan = pibt_policy(0)
        while grid.agents:
            actions = plan(grid, g_obs, g_infos)
            g_obs, g_rewards, *_, g_infos = grid.step(actions)
            _, p_rewards, *_, p_infos = phys.step(actions)
            assert np.array_equal(grid.robot_cells, phys.robot_cells)
            assert g_rewards == p_rewards
            assert min(info["min_gap"] for info in p_infos.values()) > 0.1
        assert grid.errands.tasks_done == phys.errands.tasks_done == 20  # greedy: the list ran dry


def test_the_published_instances_build_and_take_their_first_steps():
    if not LORR.is_dir():
        pytest.skip(f"LoRR instances not found at {LORR} (the shared folder beside the checkout)")
    env = lorr.fleet(LORR / "2026-examples-random/random-example_400.json", moves="rotate")
    obs, infos = env.reset(seed=0)
    policy = pibt_policy(0)
    for _ in range(20):
        obs, _, _, _, infos = env.step(policy(env, obs, infos))
    assert env.errands.errands_done > 0
    assert not any(info["refused"] for info in infos.values())
