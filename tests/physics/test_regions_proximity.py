"""The compiled proximity kernels against brute force: near pairs, the closest approach of
pairs over a path, the farthest travel, the depth of discs in walls, segment gaps."""

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from warehouse_phys.physics.regions.proximity import (
    largest_travel,
    near_pairs,
    pair_closest,
    segment_gaps,
    wall_depths,
)

coordinates = st.floats(-50, 50, allow_nan=False, width=64)


def canonical(pairs: np.ndarray) -> set[tuple[int, int]]:
    return {(int(i), int(j)) for i, j in pairs}


@settings(max_examples=80, deadline=None)
@given(
    points=arrays(np.float64, st.tuples(st.integers(0, 60), st.just(2)), elements=coordinates),
    floors=st.integers(1, 4),
    radius=st.floats(0.05, 30),
    seed=st.integers(0, 1000),
)
def test_near_pairs_are_every_pair_within_the_radius_on_one_floor(points, floors, radius, seed):
    floor = np.random.default_rng(seed).integers(floors, size=len(points))
    found = near_pairs(points, floor, radius)
    expected = {
        (i, j) for i in range(len(points)) for j in range(i + 1, len(points))
        if floor[i] == floor[j] and np.hypot(*(points[i] - points[j])) <= radius
    }  # fmt: skip
    assert canonical(found) == expected
    assert len(found) == len(expected)  # each once
    assert np.array_equal(near_pairs(points, floor, radius), found)  # the same order


def test_near_pairs_spread_over_many_floors_and_far_apart_use_few_bins():
    points = np.array([[0.0, 0.0], [1e6, 1e6], [0.5, 0.0], [1e6, 1e6 + 0.2]])
    assert canonical(near_pairs(points, np.zeros(4, dtype=np.int64), 1.0)) == {(0, 2), (1, 3)}
    many = np.arange(100_000, dtype=np.int64)
    spread = np.zeros((100_000, 2))
    assert len(near_pairs(spread, many, 1.0)) == 0  # one robot a floor: no pair


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 10_000), steps=st.integers(1, 8), n=st.integers(2, 12))
def test_pair_closest_and_largest_travel_are_the_brute_force_minimum_and_maximum(seed, steps, n):
    rng = np.random.default_rng(seed)
    path = rng.normal(size=(steps, n, 2)) * 3
    pairs = np.array([(i, j) for i in range(n) for j in range(i + 1, n)], dtype=np.int64)
    closest = pair_closest(path, pairs)
    for p, (i, j) in enumerate(pairs):
        assert closest[p] == np.sqrt(((path[:, i] - path[:, j]) ** 2).sum(axis=1)).min()
    travel = np.sqrt(((path - path[0]) ** 2).sum(axis=2)).max()
    assert math.isclose(largest_travel(path), travel, rel_tol=1e-15, abs_tol=1e-15)


def _brute_depth(row: float, col: float, blocked: np.ndarray, radius: float) -> float:
    """How deep a disc at ``(row, col)`` is into the nearest blocked cell (the distance from
    its centre to each blocked square, exactly)."""
    deepest = -np.inf
    for a in range(blocked.shape[0]):
        for b in range(blocked.shape[1]):
            if blocked[a, b]:
                top, left = a - 1 - 0.5, b - 1 - 0.5  # the square of cell (a - 1, b - 1)
                d_row = max(top - row, 0, row - (top + 1))
                d_col = max(left - col, 0, col - (left + 1))
                inside = top <= row <= top + 1 and left <= col <= left + 1
                deepest = max(deepest, radius + 0.5 if inside else radius - np.hypot(d_row, d_col))
    return deepest


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 10_000), radius=st.floats(0.05, 0.49))
def test_wall_depths_are_the_depth_into_the_nearest_wall_or_shelf(seed, radius):
    rng = np.random.default_rng(seed)
    rows, cols = 5, 6
    blocked = np.ones((rows + 2, cols + 2), dtype=bool)
    blocked[1:-1, 1:-1] = rng.random((rows, cols)) < 0.3
    free = np.argwhere(~blocked[1:-1, 1:-1])
    if not len(free):
        return
    cells = free[rng.integers(len(free), size=7)]
    row_col = cells + rng.uniform(-0.5, 0.5, size=(7, 2))
    path = row_col[None, :, ::-1] + 0.5  # (x, y) [m] of 1 m cells, the origin at 0
    depth = wall_depths(path, np.zeros((7, 2)), 1.0, blocked, radius)
    for i, (row, col) in enumerate(row_col):
        expected = _brute_depth(row, col, blocked, radius)
        assert depth[i] <= expected + 1e-12, (row, col)  # never deeper than it is
        if expected > 0:  # a disc in a wall or shelf: exactly as deep
            assert math.isclose(depth[i], expected, abs_tol=1e-12), (row, col)


def test_a_disc_pressed_into_a_shelf_edge_and_corner_has_their_depth():
    blocked = np.ones((4, 5), dtype=bool)
    blocked[1:-1, 1:-1] = [[False, True, False], [False, False, False]]  # a shelf at (0, 1)
    radius = 0.3
    # (row, col): 0.25 from the shelf's left edge; then near its bottom-left corner.
    points = np.array([[0.0, 0.25], [0.8, 0.3]])
    path = (points[:, ::-1] + 0.5)[None]
    depth = wall_depths(path, np.zeros((2, 2)), 1.0, blocked, radius)
    assert math.isclose(depth[0], radius - 0.25, abs_tol=1e-12)
    corner = np.hypot(0.5 - 0.3, 0.8 - 0.5)
    assert math.isclose(depth[1], radius - corner, abs_tol=1e-12)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 10_000))
def test_segment_gaps_are_the_closest_points_of_two_segments(seed):
    rng = np.random.default_rng(seed)
    start = rng.normal(size=(6, 2)) * 2
    end = start + rng.normal(size=(6, 2)) * rng.integers(0, 2, size=(6, 1))  # some points
    pairs = np.array([(i, j) for i in range(6) for j in range(i + 1, 6)], dtype=np.int64)
    gaps = segment_gaps(start, end, pairs)
    share = np.linspace(0, 1, 201)
    for p, (i, j) in enumerate(pairs):
        a = start[i] + share[:, None] * (end[i] - start[i])
        b = start[j] + share[:, None] * (end[j] - start[j])
        sampled = np.sqrt(((a[:, None] - b[None]) ** 2).sum(axis=2)).min()
        assert gaps[p] <= sampled + 1e-12  # never more than any pair of points
        length = np.hypot(*(end[i] - start[i])) + np.hypot(*(end[j] - start[j]))
        assert sampled - gaps[p] <= length / 200 + 1e-12  # as close as the sampling tells
