"""Recorded delays replayed: the same robots delayed at the same ticks as the record, every
interval given back, bad records refused in one line."""

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from warehouse_phys.execution.delay_replay import DelayReplay
from warehouse_phys.execution.delays import DelayConfig, DelayGenerator


@given(st.integers(0, 2**32 - 1), st.integers(1, 30), st.sampled_from([0.01, 0.1, 0.5]),
       st.sampled_from(["bernoulli", "poisson"]), st.integers(1, 9))  # fmt: skip
def test_a_replay_delays_the_generators_robots_at_the_generators_ticks(seed, n, p, model, span):
    config = DelayConfig(seed=seed, min_delay=1, max_delay=span, event_model=model, p_delay=p,
                         duration_model="uniform")  # fmt: skip
    generator = DelayGenerator(config, n)
    drawn = [generator.next_tick() for _ in range(80)]
    replay = DelayReplay(generator.intervals_json(), 80)
    for tick, delayed in enumerate(drawn):
        assert (replay.next_tick() == delayed).all(), tick
        assert (replay.remaining == np.asarray(_remaining_at(generator, tick, n))).all()
    assert replay.intervals_json() == generator.intervals_json()
    replay.rewind()
    assert replay.tick == 0
    assert replay.intervals_json() == [[] for _ in range(n)]


def _remaining_at(generator, tick, n):
    """Ticks of delay each robot had left at ``tick`` (this tick included)."""
    robot, start, end = generator.intervals()
    left = np.zeros(n, dtype=np.int64)
    on = (start <= tick) & (tick < end)
    left[robot[on]] = end[on] - tick
    return left


def test_a_replay_stops_at_the_end_of_its_record():
    replay = DelayReplay([[[0, 2]], []], 3)
    assert replay.next_tick().tolist() == [True, False]
    replay.next_tick(), replay.next_tick()
    with pytest.raises(ValueError, match="cover 3 ticks"):
        replay.next_tick()


@pytest.mark.parametrize(
    "intervals", [[[[2, 2]]], [[[3, 1]]], [[[0, 4], [2, 6]]], [[[0, 1.5]]], [[[True, 2]]], [[[1]]]]
)
def test_intervals_that_are_not_pairs_in_order_are_refused(intervals):
    with pytest.raises(ValueError, match="robot 0"):
        DelayReplay(intervals)
