"""``python -m warehouse_phys.train --eval``: a saved table evaluated, never trained.

A single robot's table is evaluated against every target of its floor (and, with
``--render``, its greedy episode watched in a window: :func:`watch`, which training's
``--render`` shows too); a fleet's table over fixed seeds beside the shortest-path
policy. The floor, the robots and the observation come from the table's file; options
that only training reads are refused (:func:`refuse_training_options`).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import gymnasium as gym

from warehouse_phys.apps.cli import Floor, UsageError
from warehouse_phys.apps.runs import EVALUATION_SEEDS, fleet_comparison
from warehouse_phys.rl.fleet_evaluation import compare_policies
from warehouse_phys.rl.greedy_policy import evaluate, greedy_action
from warehouse_phys.rl.qlearning import QLearningConfig, QTableError, load_q_table


def refuse_training_options(args: argparse.Namespace) -> None:
    """``--eval`` trains nothing and writes nothing: options that only training reads are
    refused, never silently ignored."""
    defaults = QLearningConfig()
    given = {
        "--episodes": args.episodes is not None,
        "--out": args.out is not None,
        "--overwrite": args.overwrite,
        "--robots": args.robots != 1,
        "--observation": args.observation is not None,
        "--alpha": args.alpha != defaults.alpha,
        "--gamma": args.gamma != defaults.gamma,
        "--no-gif": not args.gif,
    }
    ignored = [flag for flag, present in given.items() if present]
    if ignored:
        raise UsageError(
            f"--eval evaluates a saved table (its robots and observation come from the file) "
            f"and writes nothing: leave out {', '.join(ignored)}"
        )


def evaluate_saved(args: argparse.Namespace) -> int:
    try:
        q, metadata = load_q_table(args.eval)
    except QTableError as error:
        raise UsageError(f"--eval: {error}") from None
    table_grid = (metadata["grid_rows"], metadata["grid_cols"])
    asked = (args.rows or table_grid[0], args.cols or table_grid[1])
    if asked != table_grid:
        raise UsageError(
            f"--eval: {args.eval} holds a table for a {table_grid[0]}x{table_grid[1]} grid, "
            f"not {asked[0]}x{asked[1]}"
        )
    if args.layout is not None:
        raise UsageError("--eval: the layout comes from the table; leave --layout out")
    kind = args.env or _kind_of(metadata["env_id"])
    if metadata["layout_name"] is not None:
        floor = Floor(preset=metadata["layout_name"], max_steps=args.max_steps)
    elif metadata["layout"] is not None:
        floor = Floor(layout=tuple(metadata["layout"]), max_steps=args.max_steps)
    else:
        floor = Floor(rows=table_grid[0], cols=table_grid[1], max_steps=args.max_steps)
    robots = metadata.get("robots", 1)
    if robots > 1:
        return _evaluate_saved_fleet(args, q, metadata, floor, kind)
    env = floor.make(kind)
    env_id = env.spec.id
    evaluation = evaluate(env, q)
    env.close()
    if not args.quiet:
        print(f"evaluating {_saved_table(args.eval, metadata)} on {env_id}")
        print(evaluation.table())
    if args.render:
        watch(floor, kind, q, seed=args.seed)
    return 0


def _evaluate_saved_fleet(
    args: argparse.Namespace, q: Any, metadata: dict[str, Any], floor: Floor, kind: str
) -> int:
    """``--eval`` of a fleet's table: its greedy policy and the shortest-path baseline."""
    if args.render:
        raise UsageError("--render shows one robot in a window; a fleet's table has no window")
    robots = metadata["robots"]
    try:
        env = floor.make_fleet(kind, robots, observation=metadata.get("observation", "local"))
    except ValueError as error:
        raise UsageError(f"--eval: {error}") from None
    comparison = fleet_comparison(env, q)
    env.close()
    if not args.quiet:
        seeds = len(EVALUATION_SEEDS)
        print(f"evaluating {_saved_table(args.eval, metadata)} over {seeds} seeds")
        print(compare_policies(comparison))
    return 0


def _saved_table(path: Path, metadata: dict[str, Any]) -> str:
    """The table saved at ``path`` in words: the file, then its robots (a fleet's),
    environment, grid, episodes and seed."""
    robots = metadata.get("robots", 1)
    fleet = f"{robots} robots, " if robots > 1 else ""
    return (
        f"{path} ({fleet}{metadata['env_id']}, {metadata['grid_rows']}x{metadata['grid_cols']}, "
        f"{metadata['episodes']} episodes, seed {metadata['seed']})"
    )


def _kind_of(env_id: str) -> str:
    """ "grid" or "phys": which of the package's environments ``env_id`` is."""
    spec = gym.registry.get(env_id)
    if spec is None or not str(spec.entry_point).startswith("warehouse_phys."):
        raise UsageError(f"--eval: the table was trained on {env_id!r}; choose --env grid or phys")
    return "phys" if str(spec.entry_point).endswith("WarehousePhysicsEnv") else "grid"


def watch(floor: Floor, kind: str, q: Any, *, seed: int) -> None:
    """Play one greedy episode in a window until the target, the time limit or a closed window."""
    env = floor.make(kind, render_mode="human")
    try:
        obs, _ = env.reset(seed=seed)
        terminated = truncated = False
        while not (terminated or truncated or env.unwrapped.user_closed_window):
            obs, _, terminated, truncated, _ = env.step(greedy_action(q, obs))
    finally:
        env.close()
