"""The queued executor: plans appended after the staged actions (the start kit's pipeline),
queues cut without leaving a move waiting for one cut, square robots that never collide by
the kit's rule whatever the delays, and every queue done once delays end."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.execution.test_executor import random_fleet
from warehouse_phys.execution.plan_checks import rows_cols
from warehouse_phys.execution.queued import NO_ACTION, QueuedExecutor, queue_path
from warehouse_phys.execution.swept_squares import boxes_collide, square_corners
from warehouse_phys.execution.windows import pibt_window
from warehouse_phys.planners.pibt import PIBT
from warehouse_phys.world.headings import HEADING_MOVES
from warehouse_phys.world.traffic import neighbour_table


def all_pairs_collide(executor, before):
    """Pairs of robots whose squares collided in the tick just run (every pair checked)."""
    left, entered, done = before
    cols = executor.grid.cols
    start = square_corners(left, entered, done, executor.ticks_needed, cols)
    end = square_corners(executor.left, executor.entered, executor.done, executor.ticks_needed,
                         cols)  # fmt: skip
    i, j = np.triu_indices(len(left), 1)
    return int(boxes_collide(start[i], end[i], start[j], end[j], executor.agent_size).sum())


def run(grid, starts, goals, *, needed, horizon, p_delay, seed, ticks, size=1.0):
    """The kit's pipeline on a floor: every 10 ticks the plan made a round earlier from the
    queue's end is appended and the queues cut; delays after the commands."""
    n = len(starts)
    headings = np.random.default_rng(seed).integers(0, 4, n)
    executor = QueuedExecutor(grid, starts, needed, headings=headings, agent_size=size)
    planner = PIBT(grid, moves="rotate", seed=seed, corner_follows=False)
    rng = np.random.default_rng(seed + 1)
    pending = None
    for tick in range(ticks):
        if tick % 10 == 0:
            if pending is not None:
                before = executor.queue_actions()
                executor.append_plan(pending)
                appended = _actions_of(pending)
                executor.truncate(horizon)
                check_prefix(before, appended, executor.queue_actions())
            end, faces = executor.queue_end()
            assert np.unique(end).size == n
            pending = pibt_window(planner, rows_cols(end, grid.cols), goals, 4, headings=faces,
                                  rotations=False)  # fmt: skip
        command = executor.command()
        delayed = rng.random(n) < p_delay
        before = (executor.left.copy(), np.where(executor.done > 0, executor.entered,
                  command.target), executor.done.copy())  # fmt: skip
        report = executor.step(delayed, command)
        assert (report.go == command.ready).all()  # GO is known before the delays
        assert all_pairs_collide(executor, before) == 0, tick
    return executor


def _actions_of(path):
    """The kit's actions of a turning plan (forward 0, clockwise 1, counter 2; -1 a wait)."""
    cells = path[..., 0] * 10**6 + path[..., 1]
    turn = (path[:, 1:, 2] - path[:, :-1, 2]) % 4
    actions = np.full(turn.shape, -1)
    actions[turn == 1], actions[turn == 3] = 1, 2
    actions[cells[:, 1:] != cells[:, :-1]] = 0
    return actions


def check_prefix(before, appended, after):
    """The kit's rule: the new queue is a prefix of the old one followed by the plan's
    actions (waits left out)."""
    for old, new, plan in zip(before.tolist(), after.tolist(), appended.tolist(), strict=True):
        expected = [a for a in old if a != NO_ACTION] + [a for a in plan if a >= 0]
        got = [a for a in new if a != NO_ACTION]
        assert got == expected[: len(got)]


@settings(max_examples=12, deadline=None)
@given(st.integers(3, 7), st.integers(3, 8), st.integers(0, 2**20), st.integers(2, 14),
       st.sampled_from([1, 2, 3]), st.sampled_from([2, 4, 6]), st.sampled_from([0.0, 0.05]),
       st.sampled_from([1.0, 0.5]))  # fmt: skip
def test_square_robots_never_collide_and_every_queue_is_done_once_delays_end(
    rows, cols, bits, robots, needed, horizon, p_delay, size
):
    fleet = random_fleet(rows, cols, bits, robots, seed=bits)
    if fleet is None:
        return
    grid, starts, goals = fleet
    executor = run(grid, starts, goals, needed=needed, horizon=horizon, p_delay=p_delay,
                   seed=bits, ticks=120, size=size)  # fmt: skip
    # No new plans, no delays: every queue empties within its moves' ticks.
    bound = int((executor.queue_actions() != NO_ACTION).sum()) * needed + 1
    for _ in range(bound):
        if executor.window_done():
            break
        executor.step(np.zeros(len(starts), dtype=bool))
    assert executor.window_done()


def test_a_plan_must_start_where_the_queues_end():
    grid, starts, _ = random_fleet(5, 6, 0, 4, seed=1)
    executor = QueuedExecutor(grid, starts, 3, headings=np.zeros(4, np.int64), agent_size=1.0)
    ahead = neighbour_table(grid)[:, HEADING_MOVES]
    executor.append_plan(queue_path(executor, np.full((4, 2), 3), ahead))
    wrong = queue_path(executor, np.full((4, 2), 3), ahead)
    wrong[0, 0, 1] = (wrong[0, 0, 1] + 1) % grid.cols
    with pytest.raises(ValueError, match="queue_end"):
        executor.append_plan(wrong)


def test_square_robots_are_never_planned_to_rotate():
    # Four robots round a 2x2 block, each facing the next one's cell.
    grid, _, _ = random_fleet(4, 4, 0, 1, seed=0)
    cells = np.array([[0, 0], [0, 1], [1, 1], [1, 0]])
    headings = np.array([0, 1, 2, 3])
    executor = QueuedExecutor(grid, cells, 2, headings=headings, agent_size=1.0)
    path = queue_path(
        executor, np.zeros((4, 1), dtype=np.int64), neighbour_table(grid)[:, HEADING_MOVES]
    )
    with pytest.raises(ValueError, match="never rotate"):
        executor.append_plan(path)


def test_a_cut_queue_cuts_the_moves_that_wait_for_it():
    grid, _, _ = random_fleet(5, 8, 0, 1, seed=0)
    # A line of three robots facing east; the leader turns three times, then drives south
    # out of the line; the others wait, then follow one another east behind it.
    cells = np.array([[1, 3], [1, 2], [1, 1]])
    executor = QueuedExecutor(grid, cells, 3, headings=np.zeros(3, np.int64), agent_size=1.0)
    ahead = neighbour_table(grid)[:, HEADING_MOVES]
    actions = np.array([[1, 1, 2, 0], [3, 3, 3, 0], [3, 3, 3, 0]])
    executor.append_plan(queue_path(executor, actions, ahead))
    assert (executor.queue_actions() != NO_ACTION).sum(axis=1).tolist() == [4, 1, 1]
    executor.truncate(2)  # the leader keeps its turns: its move out is cut, and all behind it
    assert (executor.queue_actions() != NO_ACTION).sum(axis=1).tolist() == [2, 0, 0]
    assert executor.queue_end()[0].tolist() == [grid.cols + 3, grid.cols + 2, grid.cols + 1]
    with pytest.raises(ValueError, match="horizon"):
        executor.truncate(0)
