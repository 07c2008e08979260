"""Guide-path searches in batches: the same paths for any number of threads, each a path
on the floor from its source to its goal, and the guidance's plans the same whatever the
threads."""

import itertools

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.planners.test_guidance import play
from warehouse_phys.envs import fleet
from warehouse_phys.planners import graph_search
from warehouse_phys.planners.guide_searches import MAX_WORKERS, GuideSearches
from warehouse_phys.planners.traffic_guidance import TrafficGuidance
from warehouse_phys.rl.fleet_planners import planner_policy


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**16), searches=st.integers(1, 12), turning=st.booleans())
def test_a_batch_finds_the_same_paths_on_any_number_of_threads(seed, searches, turning):
    rng = np.random.default_rng(seed)
    free = rng.random((9, 11)) >= 0.2
    graph = graph_search.move_graph(free)
    cells = np.flatnonzero(free.reshape(-1))
    row, col = (cells // 11).astype(np.int32), (cells % 11).astype(np.int32)
    n = len(cells)
    flow = rng.integers(0, 3, (n, 4)).astype(np.int32)
    lanes = rng.integers(0, 2, (n, 4)).astype(np.int32)
    sources = rng.integers(0, n, searches).tolist()
    goals = rng.integers(0, n, searches).tolist()
    facings = (rng.integers(0, 4, searches) if turning else np.full(searches, -1)).tolist()
    costs = np.array([0.5, 4.0, 1.0, 1.0, 0.5])
    found = [GuideSearches(row, col, workers).search(graph, flow, lanes, sources, goals,
                                                     facings, costs)
             for workers in (1, 2, 3)]  # fmt: skip
    for other in found[1:]:
        assert [None if p is None else p.tolist() for p in other] == [
            None if p is None else p.tolist() for p in found[0]
        ]
    for path, source, goal in zip(found[0], sources, goals, strict=True):
        if path is None:
            continue
        assert path[0] == source
        assert path[-1] == goal
        for a, b in itertools.pairwise(path):
            assert b in graph[a]


def test_the_guidance_plans_the_same_on_any_number_of_threads():
    env = fleet.parallel_env(num_robots=64, layout="warehouse", lifelong=True, max_cycles=40,
                             moves="rotate")  # fmt: skip
    runs = [play(env, planner_policy("guided", 0, search_batch=8, workers=w), 0, 40)
            for w in (1, 2, 4)]  # fmt: skip
    assert runs[0] == runs[1] == runs[2]
    assert runs[0][0] == 0


def test_the_first_step_searches_in_batches_of_its_own(monkeypatch):
    """``first_search_batch``: the first step's searches (every robot's first guide path)
    run in batches of that size, later steps' in ``search_batch``'s; the same plans on any
    number of threads."""
    batches: list[list[int]] = []  # each step's batch sizes
    update, search = TrafficGuidance.update, GuideSearches.search

    def spy_update(self, *args, **kwargs):
        batches.append([])
        return update(self, *args, **kwargs)

    def spy_search(self, graph, flow, lanes, sources, *args):
        batches[-1].append(len(sources))
        return search(self, graph, flow, lanes, sources, *args)

    monkeypatch.setattr(TrafficGuidance, "update", spy_update)
    monkeypatch.setattr(GuideSearches, "search", spy_search)
    env = fleet.parallel_env(num_robots=64, layout="warehouse", lifelong=True, max_cycles=30,
                             moves="rotate")  # fmt: skip
    runs = []
    for workers in (1, 2):
        batches.clear()
        policy = planner_policy("guided", 0, first_search_batch=8, workers=workers)
        runs.append(play(env, policy, 0, 30))
        assert batches[0] == [8] * 8  # every robot's first guide path, 8 at a time
        later = [size for step in batches[1:] for size in step]
        assert later
        assert set(later) == {1}
    assert runs[0] == runs[1]
    assert runs[0][0] == 0
    batches.clear()
    one_at_a_time = planner_policy("guided", 0, first_search_batch=None)
    assert play(env, one_at_a_time, 0, 30) != runs[0]  # the batches plan otherwise
    assert batches[0] == [1] * 64
    batches.clear()
    play(env, planner_policy("guided", 0), 0, 30)
    assert batches[0] == [64]  # by default the first step's searches are one batch of 64


def test_workers_out_of_range_are_refused():
    cells = np.zeros(4, dtype=np.int32)
    for workers in (0, MAX_WORKERS + 1):
        with pytest.raises(ValueError, match="workers"):
            GuideSearches(cells, cells, workers)
