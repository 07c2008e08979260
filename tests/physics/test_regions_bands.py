"""Bands of the floor and the robots that must share a region."""

import itertools

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from warehouse_phys.physics.regions.bands import (
    SAFE_REACH,
    band_edges,
    home_bands,
    region_of_robots,
)
from warehouse_phys.physics.regions.proximity import segment_gaps
from warehouse_phys.world.grid import WarehouseGrid
from warehouse_phys.world.layouts import resolve_layout


def test_bands_hold_about_as_many_free_cells_each():
    grid = resolve_layout("warehouse")
    for regions in (1, 2, 3, 5):
        edges = band_edges(grid, regions)
        assert len(edges) == regions - 1
        assert (np.diff(edges) >= 0).all()
        free = grid.reachable_mask.sum(axis=0)
        bounds = [0, *edges.tolist(), grid.cols]
        counts = [free[a:b].sum() for a, b in itertools.pairwise(bounds)]
        assert max(counts) - min(counts) <= 2 * free.max()  # within a column or two
    assert home_bands(np.array([0.0, 22.4, 22.6, 45.0]), np.array([23])).tolist() == [0, 0, 1, 1]


def test_a_floor_narrower_than_its_bands_leaves_some_empty():
    edges = band_edges(WarehouseGrid(3, 2), 4)
    assert len(edges) == 3
    assert set(home_bands(np.array([0.0, 1.0]), edges).tolist()) <= {0, 1, 2, 3}


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 100_000), regions=st.integers(2, 4), n=st.integers(2, 80),
       moving=st.floats(0, 1))  # fmt: skip
def test_robots_whose_paths_come_within_reach_share_a_region(seed, regions, n, moving):
    rng = np.random.default_rng(seed)
    grid = WarehouseGrid(12, 20)
    start = rng.uniform(0, [11, 19], size=(n, 2))
    end = start + (rng.random((n, 1)) < moving) * rng.uniform(-1, 1, size=(n, 2))
    floors = rng.integers(2, size=n)
    edges = band_edges(grid, regions)
    region = region_of_robots(start, end, floors, edges)
    pairs = np.array([(i, j) for i in range(n) for j in range(i + 1, n) if floors[i] == floors[j]],
                     dtype=np.int64).reshape(-1, 2)  # fmt: skip
    close = pairs[segment_gaps(start, end, pairs) < SAFE_REACH]
    assert (region[close[:, 0]] == region[close[:, 1]]).all()
    home = home_bands(start[:, 1], edges)
    # A robot leaves its home band only with a group that spans bands.
    strays = np.flatnonzero(region != home)
    linked = set(close.reshape(-1).tolist())
    assert set(strays.tolist()) <= linked


def test_two_robots_meeting_across_an_edge_go_to_the_lower_numbered_ones_band():
    edges = np.array([5])
    start = np.array([[0.0, 6.0], [0.0, 4.0], [3.0, 0.0]])
    end = np.array([[0.0, 5.0], [0.0, 4.0], [3.0, 0.0]])
    assert region_of_robots(start, end, np.zeros(3, dtype=np.int64), edges).tolist() == [1, 1, 0]
    apart = np.array([[0.0, 7.0], [0.0, 4.0], [3.0, 0.0]])
    assert region_of_robots(apart, apart, np.zeros(3, dtype=np.int64), edges).tolist() == [1, 0, 0]
