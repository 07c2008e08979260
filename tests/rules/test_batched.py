"""The batched rules are the single rules for many robots at once."""

from __future__ import annotations

import numpy as np
from hypothesis import given
from hypothesis import strategies as st

from warehouse_phys.rules.batched import step_rewards
from warehouse_phys.rules.grid import step_reward

penalties = st.one_of(st.just(0.0), st.floats(0.0, 10.0, allow_nan=False))


@given(
    cases=st.lists(st.tuples(st.booleans(), st.booleans()), min_size=1, max_size=32),
    step_penalty=penalties,
    bump_penalty=penalties,
)
def test_step_rewards_equal_the_single_rule_bit_for_bit(
    cases: list[tuple[bool, bool]], step_penalty: float, bump_penalty: float
) -> None:
    arrived, stayed = (np.array(column) for column in zip(*cases, strict=True))
    batched = step_rewards(arrived, stayed, step_penalty, bump_penalty)
    single = [step_reward(a, s, step_penalty, bump_penalty) for a, s in cases]
    assert batched.dtype == np.float64
    assert batched.tobytes() == np.array(single).tobytes()


def test_step_rewards_without_a_bump_penalty_need_no_bumps() -> None:
    assert step_rewards(np.array([True, False]), None).tolist() == [1.0, 0.0]
