"""The batched rules are the single rules for many robots at once."""

from __future__ import annotations

import numpy as np
from hypothesis import assume, given
from hypothesis import strategies as st

from warehouse_phys.world.batched import BatchedRules, step_rewards
from warehouse_phys.world.grid import WarehouseGrid, step_reward

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


@st.composite
def layouts(draw):
    """Random layouts of floor, shelves (about a third) and packages, start at (0, 0)."""
    rows, cols = draw(st.integers(1, 6)), draw(st.integers(2, 7))
    symbols = draw(st.lists(st.sampled_from("..#"), min_size=rows * cols, max_size=rows * cols))
    text = ["".join(symbols[r * cols : (r + 1) * cols]) for r in range(rows)]
    text[0] = "S" + text[0][1:]
    try:
        WarehouseGrid.from_layout(text)
    except ValueError:
        assume(False)  # walled in: no cell for a package
    return text


@given(layouts())
def test_the_tables_are_the_grids_rules_on_every_cell(layout: list[str]) -> None:
    grid = WarehouseGrid.from_layout(layout)
    rules = BatchedRules(grid)
    for row in range(grid.rows):
        for col in range(grid.cols):
            cell = row * grid.cols + col
            for action in range(4):
                moved = (
                    grid.move((row, col), action) if (row, col) in grid.reachable else (row, col)
                )
                assert rules.moves[cell * 4 + action] == moved[0] * grid.cols + moved[1]
    assert rules.targets.tolist() == [r * grid.cols + c for r, c in grid.target_cells]
    assert rules.slot[rules.targets].tolist() == list(range(len(rules.targets)))
    for slot, target in enumerate(grid.target_cells):
        expected = np.array(grid.distance_map(target)).reshape(-1)
        assert rules.distance_table().reshape(len(rules.targets), -1)[slot].tolist() == (
            expected.tolist()
        )


def test_the_tables_of_a_million_cells_are_built_without_a_loop_over_cells() -> None:
    """The tables took a ``grid.move`` call per cell and action: about 4 s here."""
    import time

    shelves = np.random.default_rng(0).random((1024, 1024)) < 0.1
    shelves[0, 0] = False
    grid = WarehouseGrid.from_layout(["".join("#" if s else "." for s in row) for row in shelves])
    began = time.process_time()
    rules = BatchedRules(grid)
    assert time.process_time() - began < 1.5
    for cell in [(0, 0), (5, 7), (1023, 1023), *list(grid.reachable)[:200:7]]:
        index = cell[0] * 1024 + cell[1]
        if cell in grid.reachable:
            for action in range(4):
                row, col = grid.move(cell, action)
                assert rules.moves[index * 4 + action] == row * 1024 + col
