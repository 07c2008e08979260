"""The planners by name: golden plans on a warehouse floor, recorded before the hot paths
were optimised and kept bit for bit, and every plan granted by traffic."""

import hashlib

import numpy as np
import pytest

from warehouse_phys.envs import fleet
from warehouse_phys.rl.fleet_planners import planner_policy


def golden_run(name, moves, robots=96, steps=48, seed=0, **guidance):
    """Play the planner ``name`` on the Kiva warehouse preset, lifelong: a digest of every
    joint action (the first 16 hex digits), the moves traffic refused and the deliveries."""
    env = fleet.parallel_env(num_robots=robots, layout="warehouse", lifelong=True,
                             max_cycles=steps, moves=moves)  # fmt: skip
    policy = planner_policy(name, seed=seed, **guidance)
    observations, infos = env.reset(seed=seed)
    digest, refused, delivered = hashlib.sha256(), 0, 0
    for _ in range(steps):
        actions = policy(env, observations, infos)
        digest.update(np.array([actions[a] for a in env.possible_agents]).tobytes())
        observations, rewards, _, _, infos = env.step(actions)
        refused += sum(info["refused"] for info in infos.values())
        delivered += int(sum(rewards.values()))
    return digest.hexdigest()[:16], refused, delivered


#: Digests recorded with the planners of the commit before issue 43's changes (the
#: guidance, PIBT and the operations as they were): the defaults must keep them (96
#: robots: the first step's searches are too few for batches, ``FIRST_BATCH_SHARE``).
GOLDEN = {
    ("guided", "grid"): ("55a9c4e7c186cddd", 0, 106),
    ("guided", "rotate"): ("8a724c70d29be3b4", 0, 87),
    ("pibt", "rotate"): ("1f8c694f9fbf333b", 0, 71),
    ("guided-ops", "rotate"): ("c8356dbdcf585b72", 0, 89),
}


@pytest.mark.parametrize(("name", "moves"), sorted(GOLDEN))
def test_golden_plans_of_the_defaults(name, moves):
    assert golden_run(name, moves) == GOLDEN[(name, moves)]


#: Runs whose plans must not depend on the process nor on the threads: the repairs, the
#: guidance's batched searches on one thread here and two in the other process, and lanes
#: learned from the traffic over the floor's lanes.
ACROSS = [
    ("guided-repair", {}, {}),
    ("guided-ops-repair", {}, {}),
    ("guided", {"search_batch": 8, "workers": 1}, {"search_batch": 8, "workers": 2}),
    ("guided", *[{"learned_lane_paths": 2, "learn_period": 4, "floor_lane_paths": 2}] * 2),
]


def test_plans_are_granted_and_the_same_in_another_process_and_on_other_threads(run_python):
    here = [golden_run(name, "rotate", robots=64, steps=32, **mine) for name, mine, _ in ACROSS]
    there = run_python(
        "from tests.rl.test_fleet_planners import ACROSS, golden_run; "
        "print([golden_run(name, 'rotate', robots=64, steps=32, **theirs) "
        "for name, _, theirs in ACROSS])"
    )
    assert there.strip() == str(here)
    assert all(refused == 0 for _, refused, _ in here)


def test_repair_settings_pass_through_the_planners_names():
    policy = planner_policy("guided-repair", 0, neighbourhood=4, iterations=10,
                            repair_time_limit=0.2, floor_lane_paths=1)  # fmt: skip
    assert policy.repair == {"neighbourhood": 4, "iterations": 10, "time_limit": 0.2}
    assert policy.config.floor_lane_paths == 1
    assert planner_policy("guided-repair", 0).config.floor_lane_paths == 2  # its own default
    assert planner_policy("guided", 0).config.floor_lane_paths == 0
    with pytest.raises(TypeError):
        planner_policy("guided", 0, neighbourhood=4)  # no repair to set
