"""The guidance's configuration refuses every value out of its range."""

import pytest

from warehouse_phys.planners.guidance_config import MAX_LANE_PATHS, GuidanceConfig


@pytest.mark.parametrize(
    "bad",
    [{"vertex_weight": -1}, {"heuristic_weight": 0.5}, {"window": 0}, {"max_searches": -1},
     {"max_searches": 1.5}, {"later_max_searches": -1}, {"later_max_searches": True},
     {"time_limit": -0.1}, {"refresh": -2}, {"turn_cost": -1}, {"first_time_limit": -1},
     {"turn_traffic_weight": -0.5}, {"turn_contraflow_weight": -1.0},
     {"turn_lane_paths": -1}, {"turn_lane_paths": MAX_LANE_PATHS + 1},
     {"turn_lane_paths": 1.5}, {"turn_lane_paths": True}, {"floor_lane_paths": -1},
     {"floor_lane_paths": 2.0}, {"search_batch": 0}, {"search_batch": 2.0},
     {"first_search_batch": 0}, {"first_search_batch": True}, {"workers": 2.5},
     {"workers": 0}, {"workers": 65},
     {"reroute": -1}, {"reroute": 2.0}, {"reroute": True}],
)  # fmt: skip
def test_nonsense_guidance_is_refused(bad):
    with pytest.raises((ValueError, TypeError), match=next(iter(bad)).split("_")[0]):
        GuidanceConfig(**bad)


def test_the_first_step_searches_in_batches_on_every_core_the_process_may_use(monkeypatch):
    from warehouse_phys.planners import guidance_config

    assert GuidanceConfig().first_search_batch == guidance_config.FIRST_SEARCH_BATCH == 64
    monkeypatch.setattr(guidance_config.os, "sched_getaffinity", lambda pid: {3})
    assert GuidanceConfig().workers == 1  # a process narrowed to one core (taskset)
    monkeypatch.setattr(guidance_config.os, "sched_getaffinity", lambda pid: set(range(100)))
    assert GuidanceConfig().workers == guidance_config.DEFAULT_MAX_WORKERS == 8
    assert GuidanceConfig(workers=3).workers == 3
    monkeypatch.delattr(guidance_config.os, "sched_getaffinity")  # no affinity (macOS)
    monkeypatch.setattr(guidance_config.os, "cpu_count", lambda: 6)
    assert GuidanceConfig().workers == 6
