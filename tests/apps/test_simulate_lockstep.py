"""The lock-step run of ``simulate``: deliveries, waits, frames and one-shot measures."""

import pytest

from tests.apps.test_simulate import MAPS
from warehouse_phys.apps.simulate.lockstep import simulate
from warehouse_phys.envs import fleet
from warehouse_phys.rl.fleet_evaluation import evaluate_fleet, shortest_path_policy


def test_the_simulation_counts_deliveries_waits_and_frames():
    env = fleet.parallel_env(num_robots=5, layout="aisles", lifelong=True, max_cycles=40)
    result, frames = simulate(env, shortest_path_policy, steps=40, seed=1, frames=8)
    assert result.steps == 40
    assert result.throughput == result.deliveries.sum() / 40
    assert result.deliveries.sum() == env.deliveries.sum()
    assert result.waits.shape == (7, 9)
    assert (
        result.waits[[r for r, _ in env.grid.shelves], [c for _, c in env.grid.shelves]].sum() == 0
    )
    assert len(frames) == 8  # the first, then evenly spread
    assert frames[0].shape == (7 * 24, 9 * 24, 3)


def test_frames_are_spread_evenly_and_bounded():
    env = fleet.parallel_env(num_robots=2, lifelong=True, max_cycles=100)
    _, frames = simulate(env, shortest_path_policy, steps=100, frames=64)
    assert len(frames) == 64
    _, frames = simulate(env, shortest_path_policy, steps=5, frames=64)
    assert len(frames) == 6  # the reset and each step


@pytest.mark.skipif(
    not (MAPS / "warehouse-large-140-500.map").is_file(),
    reason=f"no benchmark maps in {MAPS} (warehouse-large-140-500.map)",
)
def test_a_frame_costs_less_than_a_step_on_the_largest_warehouse_map():
    import gc

    from warehouse_phys.drawing import map_frames as render
    from warehouse_phys.rl.fleet_planners import pibt_policy

    env = fleet.parallel_env(layout=str(MAPS / "warehouse-large-140-500.map"), num_robots=1000,
                             max_cycles=16, observation="local")  # fmt: skip
    render._floor_image.cache_clear()
    gc.freeze()  # as the command does: a full collection would land in a step or a frame
    try:
        result, frames = simulate(env, pibt_policy(seed=0), steps=16, frames=17)
    finally:
        gc.unfreeze()
    assert len(frames) == 17
    assert render._floor_image.cache_info().misses == 1  # 38,000 shelves painted once
    timing = result.timing()  # CPU time, measured in the same process
    assert timing["median_frame"] <= timing["median_step"]
    assert timing["frames"] <= result.cpu_seconds


@pytest.mark.parametrize(("on_delivery", "seed"), [("park", 2), ("leave", 2), ("park", 3)])
def test_a_one_shot_run_measures_as_evaluate_fleet_does(on_delivery, seed):
    env = fleet.parallel_env(num_robots=4, layout="aisles", on_delivery=on_delivery,
                             max_cycles=30)  # fmt: skip
    evaluation = evaluate_fleet(env, shortest_path_policy, seeds=range(seed, seed + 1))
    result, _ = simulate(env, shortest_path_policy, steps=30, seed=seed)
    assert result.delivered == evaluation.delivered
    assert result.makespan == evaluation.makespan
    assert result.sum_of_costs == evaluation.sum_of_costs
    assert int(result.shortest.sum()) == evaluation.all_shortest_steps
    assert result.walled_off == evaluation.walled_off
    assert result.refused == evaluation.refused
    assert "makespan" in result.summary()
    assert result.to_json()["sum_of_costs"] == result.sum_of_costs
