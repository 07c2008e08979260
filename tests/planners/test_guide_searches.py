"""Guide-path searches in batches: the same paths for any number of threads, each a path
on the floor from its source to its goal, and the guidance's plans the same whatever the
threads."""

import itertools
import multiprocessing
import os

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.planners.test_guidance import play
from warehouse_phys.envs import fleet
from warehouse_phys.planners import graph_search
from warehouse_phys.planners.guidance_config import GuidanceConfig
from warehouse_phys.planners.guide_searches import MAX_WORKERS, GuideSearches
from warehouse_phys.planners.traffic_guidance import TrafficGuidance
from warehouse_phys.rl.fleet_planners import planner_policy
from warehouse_phys.world.grid import WarehouseGrid


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
    searchers = [GuideSearches(row, col, workers) for workers in (1, 2, 3)]
    found = [searcher.search(graph, flow, lanes, sources, goals, facings, costs)
             for searcher in searchers]  # fmt: skip
    for other in found[1:]:
        assert [None if p is None else p.tolist() for p in other] == [
            None if p is None else p.tolist() for p in found[0]
        ]
    # The cells expanded are the batch's work: the same on any number of threads, at
    # least one a search that moves (its source), at most every cell a search.
    assert len({searcher.expanded for searcher in searchers}) == 1
    moving = sum(source != goal for source, goal in zip(sources, goals, strict=True))
    assert moving <= searchers[0].expanded <= moving * n
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


def first_step_batches(monkeypatch, robots, steps=2, **config):
    """Each step's batch sizes, and every robot's guide path after the steps, for
    ``robots`` robots crossing a 40 x 40 open floor (turning, new goals every step)."""
    batches: list[list[int]] = []
    search = GuideSearches.search

    def spy(self, graph, flow, lanes, sources, *args):
        batches[-1].append(len(sources))
        return search(self, graph, flow, lanes, sources, *args)

    rng = np.random.default_rng(7)
    guidance = TrafficGuidance(WarehouseGrid(40, 40), GuidanceConfig(**config))
    here = rng.choice(1600, robots, replace=False)
    facing = rng.integers(0, 4, robots)
    with monkeypatch.context() as patched:
        patched.setattr(GuideSearches, "search", spy)
        for _ in range(steps):
            batches.append([])
            guidance.update(here, rng.choice(1600, robots), np.ones(robots, dtype=bool),
                            facing=facing)  # fmt: skip
    paths = guidance._paths
    found = [paths.pool[paths.start[i] : paths.start[i] + paths.moves[i] + 1].tolist()
             for i in range(robots)]  # fmt: skip
    return batches, found


def test_the_first_step_searches_in_batches_of_its_own(monkeypatch):
    """``first_search_batch``: the first step's searches (every robot's first guide path)
    run in batches of that size, at most a hundredth of them (``FIRST_BATCH_SHARE``),
    later steps' in ``search_batch``'s; the same paths on any number of threads."""
    batched, one, two = ({"first_search_batch": 8, "workers": w} for w in (1, 1, 2))
    batches, found = first_step_batches(monkeypatch, 900, **batched)
    assert batches[0] == [8] * 112 + [4]  # 900 first guide paths, 8 at a time
    assert batches[1] == [1] * 900  # every robot's new goal, one at a time
    assert first_step_batches(monkeypatch, 900, **two) == (batches, found)
    one_at_a_time = first_step_batches(monkeypatch, 900, steps=1, first_search_batch=None)
    assert one_at_a_time[0] == [[1] * 900]
    # The batches plan otherwise: paths blind to the others of their batch.
    assert one_at_a_time[1] != first_step_batches(monkeypatch, 900, steps=1, **batched)[1]
    # A hundredth of 500 searches: batches of 5, whatever first_search_batch allows.
    assert first_step_batches(monkeypatch, 500, steps=1)[0] == [[5] * 100]
    assert first_step_batches(monkeypatch, 150, steps=1, **one)[0] == [[1] * 150]


def test_threads_and_their_buffers_last_only_while_batches_need_them():
    """A thread's search buffers are made when a batch first needs them; the first
    step's threads and buffers are let go after it when later steps search one at a time,
    and kept when they search in batches."""
    rng = np.random.default_rng(3)
    here, goal = rng.choice(1600, 900, replace=False), rng.choice(1600, 900)
    searches = GuideSearches(np.zeros(5, dtype=np.int32), np.zeros(5, dtype=np.int32), 4)
    assert searches._buffers[0] is not None
    assert searches._buffers[1:] == [None] * 3
    for later, kept in ((1, False), (8, True)):
        config = GuidanceConfig(first_search_batch=8, search_batch=later, workers=2)
        guidance = TrafficGuidance(WarehouseGrid(40, 40), config)
        guidance.update(here, goal, np.ones(900, dtype=bool))
        assert (guidance._searches._pool is not None) == kept
        assert (guidance._searches._buffers[1] is not None) == kept
        guidance.update(here, rng.choice(1600, 900), np.ones(900, dtype=bool))  # still works


def search_twice_then_exit(searches, batch):
    found = [searches.search(*batch), searches.search(*batch)]
    os._exit(0 if all(path is not None for path in found[1]) else 1)


def test_a_forked_process_searches_on_threads_of_its_own():
    """A process forked after the threads started (a multiprocessing pool with fork) has
    none of them: its searches start threads of their own rather than wait for ever."""
    free = np.ones((6, 6), dtype=bool)
    cells = np.arange(36)
    row, col = (cells // 6).astype(np.int32), (cells % 6).astype(np.int32)
    searches = GuideSearches(row, col, workers=2)
    flow = np.zeros((36, 4), dtype=np.int32)
    batch = (graph_search.move_graph(free), flow, flow.copy(), [0, 5, 30], [35, 30, 5],
             [-1, -1, -1], np.array([0.5, 1.0, 1.0, 1.0, 0.5]))  # fmt: skip
    assert all(path is not None for path in searches.search(*batch))  # the threads start
    child = multiprocessing.get_context("fork").Process(
        target=search_twice_then_exit, args=(searches, batch)
    )
    child.start()
    child.join(timeout=60)
    if child.exitcode is None:
        child.kill()
    assert child.exitcode == 0


def test_workers_out_of_range_are_refused():
    cells = np.zeros(4, dtype=np.int32)
    for workers in (0, MAX_WORKERS + 1):
        with pytest.raises(ValueError, match="workers"):
            GuideSearches(cells, cells, workers)
