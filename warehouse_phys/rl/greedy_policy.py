"""The greedy policy of a single robot's Q-table, and how it does: its action for an
observation (:func:`greedy_action`), its action and value on every cell for one target
(:func:`greedy_actions`, :func:`state_values`), and its evaluation from the start against
every target (:func:`evaluate`, an :class:`Evaluation`). With them, the check that an
environment is a warehouse a table fits (:func:`grid_size`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import gymnasium as gym
import numpy as np

from warehouse_phys.planners.distances import UNREACHABLE
from warehouse_phys.world.grid import Cell
from warehouse_phys.world.traffic import neighbour_table


def greedy_action(q: np.ndarray, obs: Sequence[int] | np.ndarray) -> int:
    """The greedy action for observation ``obs``: the first of the best-valued actions."""
    return int(q[tuple(int(v) for v in obs)].argmax())


def greedy_actions(q: np.ndarray, target: tuple[int, int]) -> np.ndarray:
    """The greedy action in every cell when the package is on ``target``.

    Returns an ``(R, C)`` int64 array of action values; ``-1`` marks cells whose
    four values are all still zero (never updated: unvisited, the target itself,
    shelves), where the greedy choice means nothing.
    """
    values = _target_slice(q, target)
    actions = values.argmax(axis=-1).astype(np.int64)
    actions[~values.any(axis=-1)] = -1
    return actions


def state_values(q: np.ndarray, target: tuple[int, int]) -> np.ndarray:
    """``max_a Q(cell, target, a)`` for every cell: an ``(R, C)`` float64 array.

    With reward 1 on arrival and discount ``gamma``, a cell ``d`` steps from the
    target has the value ``gamma ** (d - 1)`` under the optimal policy; a
    trained table approaches that.
    """
    return _target_slice(q, target).max(axis=-1).astype(np.float64)


def _target_slice(q: np.ndarray, target: tuple[int, int]) -> np.ndarray:
    if q.ndim != 5 or q.shape[:2] != q.shape[2:4] or q.shape[4] != 4:
        raise ValueError(f"expected a Q-table of shape (R, C, R, C, 4), got {q.shape}")
    row, col = (int(v) for v in target)
    if not (0 <= row < q.shape[2] and 0 <= col < q.shape[3]):
        raise ValueError(f"target {(row, col)} is off the {q.shape[2]}x{q.shape[3]} grid")
    return q[:, :, row, col, :]


# ------------------------------------------------------------------ evaluation
@dataclass(frozen=True)
class TargetResult:
    """How the greedy policy did from the start against one target."""

    target: Cell
    #: Actions taken to reach the target, or ``None`` if it never got there.
    steps: int | None
    #: The fewest actions that reach it.
    optimal_steps: int

    @property
    def reached(self) -> bool:
        return self.steps is not None

    @property
    def optimal(self) -> bool:
        return self.steps == self.optimal_steps


@dataclass(frozen=True)
class Evaluation:
    """The greedy policy against every possible target."""

    results: tuple[TargetResult, ...]

    @property
    def reached(self) -> int:
        """How many targets the policy reached."""
        return sum(r.reached for r in self.results)

    @property
    def optimal(self) -> int:
        """How many targets it reached by a shortest path."""
        return sum(r.optimal for r in self.results)

    @property
    def all_optimal(self) -> bool:
        """Whether it reached every target by a shortest path."""
        return self.optimal == len(self.results)

    def summary(self) -> str:
        """One line: how many of the targets were reached, and how many optimally."""
        n = len(self.results)
        if self.all_optimal:
            return (
                "the target reached by a shortest path"
                if n == 1
                else (f"all {n} targets reached by a shortest path")
            )
        return f"{self.reached} of {n} targets reached, {self.optimal} of them by a shortest path"

    def table(self) -> str:
        """The results as a text table, one target per line, then the summary."""
        lines = [f"{'target':<10}{'steps':>7}{'optimal':>9}  result"]
        for r in self.results:
            if not r.reached:
                verdict, steps = "not reached", "-"
            else:
                verdict = "shortest path" if r.optimal else f"{r.steps - r.optimal_steps} too many"
                steps = str(r.steps)
            target = f"({r.target[0]}, {r.target[1]})"
            lines.append(f"{target:<10}{steps:>7}{r.optimal_steps:>9}  {verdict}")
        lines.append(self.summary())
        return "\n".join(lines)

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready summary with one entry per target."""
        return {
            "targets": len(self.results),
            "reached": self.reached,
            "optimal": self.optimal,
            "all_optimal": self.all_optimal,
            "results": [
                {"target": list(r.target), "steps": r.steps, "optimal_steps": r.optimal_steps}
                for r in self.results
            ],
        }


def evaluate(env: gym.Env, q: np.ndarray, *, max_steps: int | None = None) -> Evaluation:
    """Run the greedy policy of ``q`` from the start against every possible target.

    Each target of ``env.unwrapped.grid.target_cells`` is tried from the floor's start,
    as ``reset(options={"target": ...})`` places it. An episode stops on the target, at
    the environment's time limit, or after ``max_steps`` actions (default: the time
    limit of ``env.spec``, else 4 x the number of cells), whichever comes first.

    The episodes are played on the floor's rules, every target at once with array
    operations (both environments move by those rules; the physics twin is proven to
    end every move on the grid's cell), and a greedy walk that has made as many moves as
    the floor has reachable cells without arriving has gone round a loop it never
    leaves, so it stops there: the cost is bounded by the floor's size, not by the time
    limit (a 60 x 60 floor evaluates in well under a second).

    Raises:
        ValueError: if the table's shape does not fit the environment's grid.
    """
    rows, cols = grid_size(env)
    if q.shape != (rows, cols, rows, cols, 4):
        raise ValueError(
            f"Q-table of shape {q.shape} does not fit a {rows}x{cols} grid "
            f"(expected {(rows, cols, rows, cols, 4)})"
        )
    if max_steps is None:
        spec = getattr(env, "spec", None)
        max_steps = (spec.max_episode_steps if spec else None) or 4 * rows * cols
    grid = env.unwrapped.grid
    targets = np.array(grid.target_cells, dtype=np.int64).reshape(-1, 2)
    goal = targets[:, 0] * cols + targets[:, 1]
    start = grid.start[0] * cols + grid.start[1]
    moves = neighbour_table(grid)
    cell = np.full(len(targets), start, dtype=np.int64)
    steps = np.full(len(targets), -1, dtype=np.int64)
    walking = np.flatnonzero(cell != goal)
    for step in range(1, min(max_steps, len(grid.reachable)) + 1):
        if not walking.size:
            break
        row, col = np.divmod(cell[walking], cols)
        action = q[row, col, targets[walking, 0], targets[walking, 1]].argmax(axis=1)
        after = moves[cell[walking], action]
        stuck = after == cell[walking]  # a bump: the same action again, for ever
        cell[walking] = after
        arrived = after == goal[walking]
        steps[walking[arrived]] = step
        walking = walking[~(arrived | stuck)]
    # The floor's own breadth-first search from the start (the distances are the same
    # both ways): one robot's evaluation need not load the fleets' compiled searches.
    from_start = grid.distance_array(grid.start).reshape(-1)[goal]
    optimal = np.where(from_start >= 0, from_start, UNREACHABLE)
    return Evaluation(
        tuple(
            TargetResult(Cell(int(r), int(c)), None if n < 0 else int(n), int(best))
            for (r, c), n, best in zip(
                targets.tolist(), steps.tolist(), optimal.tolist(), strict=True
            )
        )
    )


def grid_size(env: gym.Env) -> tuple[int, int]:
    """The ``(rows, cols)`` of ``env``'s floor, or a ``ValueError`` if ``env`` is not a
    warehouse environment (``grid_rows``, ``grid_cols`` and 4 actions)."""
    base = env.unwrapped
    rows, cols = getattr(base, "grid_rows", None), getattr(base, "grid_cols", None)
    if rows is None or cols is None or getattr(env.action_space, "n", None) != 4:
        raise ValueError(
            f"{type(base).__name__} is not a warehouse environment: Q-learning here needs "
            "grid_rows, grid_cols and 4 actions"
        )
    return rows, cols
