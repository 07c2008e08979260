"""The start kit's square robots: its collision rule restated in single precision, held to an
exact brute force, the follow rule it gives the executor, and the neighbourhood check."""

from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from warehouse_phys.execution.swept_squares import (
    boxes_collide,
    checked_size,
    colliding_pairs,
    corners_after_tick,
    may_follow_squares,
    square_corners,
)

#: How far from touching an exact verdict must be for the kit's single precision to agree
#: with it (far above a float's step at column 1,000, 1.2e-4).
MARGIN = Fraction(1, 1000)


def exact_overlap_depth(a0, a1, b0, b1, size):
    """The most two squares moving linearly overlap during a tick, by brute force over the
    instants where the overlap can be largest (the ends and where an axis' gap is 0):
    ``min(size - |dx|, size - |dy|)`` maximised, in exact fractions."""
    d0 = [Fraction(a0[k]) - Fraction(b0[k]) for k in range(2)]
    dv = [
        (Fraction(a1[k]) - Fraction(a0[k])) - (Fraction(b1[k]) - Fraction(b0[k])) for k in range(2)
    ]
    times = {Fraction(0), Fraction(1)}
    for k in range(2):
        if dv[k]:
            t = -d0[k] / dv[k]
            if 0 <= t <= 1:
                times.add(t)
            for edge in (size, -size):  # where one axis starts or stops overlapping
                t = (edge - d0[k]) / dv[k]
                if 0 <= t <= 1:
                    times.add(t)
    best = None
    for t in times:
        depth = min(size - abs(d0[k] + dv[k] * t) for k in range(2))
        best = depth if best is None else max(best, depth)
    return best


position = st.builds(lambda col, row, k, t: (Fraction(col) + Fraction(k, t), Fraction(row)),
                     st.integers(0, 1000), st.integers(0, 200), st.integers(0, 9),
                     st.integers(1, 10))  # fmt: skip


@settings(max_examples=400)
@given(position, position, position, position, st.sampled_from([1, Fraction(1, 2), Fraction(3, 4)]),
       st.booleans())  # fmt: skip
def test_the_kits_rule_agrees_with_an_exact_brute_force_away_from_touching(a0, a1, b0, b1, size,
                                                                         swap):  # fmt: skip
    if swap:  # motions along y too
        a0, a1, b0, b1 = ((p[1], p[0]) for p in (a0, a1, b0, b1))
    depth = exact_overlap_depth(a0, a1, b0, b1, Fraction(size))
    f32 = [np.array([[float(v) for v in p]], dtype=np.float32) for p in (a0, a1, b0, b1)]
    verdict = bool(boxes_collide(*f32, float(size))[0])
    if depth > MARGIN:
        assert verdict, (a0, a1, b0, b1, size, depth)
    elif depth < -MARGIN:
        assert not verdict, (a0, a1, b0, b1, size, depth)


def test_touching_squares_do_not_collide_and_overlapping_ones_do():
    at = np.array([[5.0, 2.0]], dtype=np.float32)
    beside = np.array([[6.0, 2.0]], dtype=np.float32)
    inside = np.array([[5.9, 2.0]], dtype=np.float32)
    assert not boxes_collide(at, at, beside, beside, 1.0)[0]
    assert boxes_collide(at, at, inside, inside, 1.0)[0]
    assert not boxes_collide(at, at, inside, inside, 0.5)[0]  # half-cell squares: apart
    # One sweeping through the other within the tick, apart at both ends.
    assert boxes_collide(np.array([[3.0, 2.0]], np.float32), np.array([[7.0, 2.0]], np.float32),
                         at, at, 1.0)[0]  # fmt: skip


def test_corners_follow_the_kits_real_locations():
    cols = 600
    left = np.array([2 * cols + 500, 2 * cols + 500, 2 * cols + 500, 2 * cols + 500])
    entered = left + np.array([1, -1, cols, 0])
    done = np.array([1, 2, 1, 2])
    corners = square_corners(left, entered, done, np.full(4, 3), cols)
    third = np.float32(1) / np.float32(3)
    assert corners[0].tolist() == [np.float32(500) + third, 2.0]
    assert corners[1].tolist() == [np.float32(500) - np.float32(2) / np.float32(3), 2.0]
    assert corners[2].tolist() == [500.0, np.float32(2) + third]
    assert corners[3].tolist() == [500.0, 2.0]  # a turn: no offset
    ended = corners_after_tick(left[:1], entered[:1], np.array([2]), np.array([3]), cols)
    assert ended.tolist() == [[501.0, 2.0]]


def pair(cols, leader_dir, follower_dir, l_done, f_done, needed=3):
    """A follower entering cell (2, 500) from the west; its leader leaving it east or south."""
    cell = 2 * cols + 500
    left = np.array([cell, cell - 1])
    target = np.array([cell + (1 if leader_dir == "east" else cols), cell])
    return left, target, np.array([l_done, f_done]), np.full(2, needed)


@pytest.mark.parametrize("l_done", [1, 2])
def test_a_straight_follower_stays_a_tick_behind_its_leader(l_done):
    cols = 600
    left, target, done, needed = pair(cols, "east", "east", l_done, 0)
    alone, together = may_follow_squares(np.array([1]), np.array([0]), left, target, done,
                                         needed, cols, 1.0)  # fmt: skip
    assert alone.tolist() == [True]
    assert together.tolist() == [False]
    left, target, done, needed = pair(cols, "east", "east", l_done, l_done)
    alone, _ = may_follow_squares(np.array([1]), np.array([0]), left, target, done, needed,
                                  cols, 1.0)  # fmt: skip
    assert alone.tolist() == [False]  # one tick more would close in on a leader that stops


def test_a_corner_follower_waits_for_its_leader_to_be_gone_and_smaller_squares_need_less():
    cols = 600
    for l_done in (1, 2):
        left, target, done, needed = pair(cols, "south", "east", l_done, 0)
        alone, _ = may_follow_squares(np.array([1]), np.array([0]), left, target, done,
                                      needed, cols, 1.0)  # fmt: skip
        assert alone.tolist() == [False]
    left, target, done, needed = pair(cols, "south", "east", 2, 0)
    alone, _ = may_follow_squares(np.array([1]), np.array([0]), left, target, done, needed,
                                  cols, 0.5)  # fmt: skip
    assert alone.tolist() == [True]


def test_nobody_closes_in_on_a_leader_at_rest():
    cols = 600
    left, target, done, needed = pair(cols, "east", "east", 0, 0)
    alone, _ = may_follow_squares(np.array([1]), np.array([0]), left, target, done, needed,
                                  cols, 0.25)  # fmt: skip
    assert alone.tolist() == [False]


@given(st.integers(0, 2**32 - 1), st.integers(2, 40))
def test_colliding_pairs_finds_every_pair_a_brute_force_finds(seed, n):
    rng = np.random.default_rng(seed)
    cols = 30
    cells = rng.choice(12 * cols, size=n, replace=False)
    d_row, d_col = np.array([(0, 1), (0, -1), (1, 0), (-1, 0), (0, 0)])[rng.integers(0, 5, n)].T
    row, col = np.divmod(cells, cols)
    inside = (row + d_row >= 0) & (row + d_row < 12) & (col + d_col >= 0) & (col + d_col < cols)
    entered = np.where(inside, (row + d_row) * cols + col + d_col, cells)
    needed = rng.integers(1, 5, n)
    done = np.where(entered != cells, rng.integers(0, needed), 0)
    start = square_corners(cells, entered, done, needed, cols)
    end = corners_after_tick(cells, entered, done, needed, cols)
    found = {tuple(p) for p in colliding_pairs(start, end, cells, 1.0, cols).tolist()}
    i, j = np.triu_indices(n, 1)
    hit = boxes_collide(start[i], end[i], start[j], end[j], 1.0)
    brute = {(int(a), int(b)) for a, b in zip(i[hit], j[hit], strict=True)}
    near = {(a, b) for a, b in brute
            if max(abs(cells[a] // cols - cells[b] // cols),
                   abs(cells[a] % cols - cells[b] % cols)) <= 2}  # fmt: skip
    assert found == near
    assert brute == near  # squares of side 1 reach no robot further than two cells away


@pytest.mark.parametrize("bad", [0, -1, 1.5, float("nan")])
def test_a_side_outside_zero_to_one_is_refused(bad):
    with pytest.raises(ValueError, match="agent_size"):
        checked_size(bad)
    with pytest.raises(TypeError, match="agent_size"):
        checked_size("1")
