"""``python -m warehouse_phys.train``: train tabular Q-learning, save, plot and evaluate.

With no arguments: 1000 episodes with the tutorial's hyper-parameters on the
physics-backed environment, headless, with a progress bar; then the run folder
``runs/<env>-seed<seed>-<time>/`` receives the table (``qtable.npz``), the
learning curve (``learning_curve.png``), an animated GIF of the greedy policy's
episode with the same seed (``episode.gif``; ``--no-gif`` leaves it out) and a
JSON summary (``summary.json``), and the greedy policy is evaluated against
every target and printed as a table.

    python -m warehouse_phys.train --env grid --episodes 2000 --seed 3
    python -m warehouse_phys.train --eval runs/phys-seed0-20260101-120000/qtable.npz
    python -m warehouse_phys.train --rows 3 --cols 3 --render
    python -m warehouse_phys.train --env grid --layout aisles
    python -m warehouse_phys.train --robots 3

With ``--robots N`` (N > 1) a fleet of N robots on one floor trains independent
Q-learners that share one table over their local observations, or with
``--observation neighbours`` over those and which adjacent cells hold a robot
(five actions: the moves and WAIT; see :mod:`warehouse_phys.rl.fleet_learning`);
training episodes last at most 200 joint steps on floors up to 25 cells across.
The run folder holds the same four files, the GIF showing the fleet, and the
learned policy (greedy, with a random walk for a robot that stops making
progress) is evaluated over fixed seeds beside a shortest-path policy that waits
when blocked, a uniformly random policy and the PIBT planner: packages
delivered, steps against the shortest paths, refused moves and episodes stuck at
the time limit, with a line for each policy that delivers fewer packages than
the shortest-path policy or random.

    python -m warehouse_phys.train --env grid --robots 4 --observation neighbours

Bad arguments and unusable tables end with exit status 2 and a one-line
message, before anything is written. The algorithm lives in
:mod:`warehouse_phys.rl.qlearning`; this module is only the command line, and ``--eval``
(a saved table evaluated) is :mod:`warehouse_phys.apps.train_eval`.
"""

from __future__ import annotations

from warehouse_phys._starting import command_interrupts

# python -m warehouse_phys.apps.<app> runs this module as __main__: Ctrl-C while it
# imports is the command's one line, as with the short name's.
with command_interrupts(__name__ == "__main__"):
    import argparse
    import sys
    import time
    from collections.abc import Callable
    from pathlib import Path
    from typing import Any, TypeVar

    from warehouse_phys.apps.cli import (
        DEFAULT_ENV,
        ArgumentParser,
        Floor,
        UsageError,
        add_env_argument,
        add_floor_arguments,
        add_robots_argument,
        bounded_int,
        floor_from_args,
        opened_run_folder,
        warnings_in_one_line,
    )
    from warehouse_phys.apps.interrupts import interruption, stops_on_sigterm
    from warehouse_phys.apps.runs import (
        CURVE_FILE,
        EVALUATION_SEEDS,
        GIF_FILE,
        RUN_FILES,
        SUMMARY_FILE,
        TABLE_FILE,
        train_fleet_run,
        train_run,
    )
    from warehouse_phys.apps.train_eval import evaluate_saved, refuse_training_options, watch
    from warehouse_phys.drawing.display import NoDisplayError, check_display
    from warehouse_phys.envs.fleet.setup import MAX_PHYSICS_ROBOTS
    from warehouse_phys.files.runfolder import RunFolder, RunFolderError, RunWriteError
    from warehouse_phys.rl.fleet_evaluation import compare_policies
    from warehouse_phys.rl.greedy_policy import Evaluation
    from warehouse_phys.rl.qlearning import QLearningConfig, check_training_memory, table_tail
    from warehouse_phys.world.layouts import PRESETS

PROG = "python -m warehouse_phys.train"
Outcome = TypeVar("Outcome")
#: Training episodes of a fleet, unless --episodes says otherwise: enough for the
#: default floor's fleets of two to four robots to deliver every package in training.
FLEET_EPISODES = 3000
DEFAULT_RUNS_DIR = Path("runs")


def _fraction(low_open: bool) -> Any:
    interval = "(0, 1]" if low_open else "[0, 1]"

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(
                f"expected a number in {interval}, got {text!r}"
            ) from None
        if not (0 < value <= 1 if low_open else 0 <= value <= 1):
            # as given: 1.0000001 printed with {:g} reads as 1, which is in the interval
            raise argparse.ArgumentTypeError(f"expected a number in {interval}, got {text}")
        return value

    return parse


def _folder(text: str) -> Path:
    """An argument type: a folder's path, never the empty string (which means ".")."""
    if not text.strip():
        raise argparse.ArgumentTypeError("expected a folder, got an empty path")
    return Path(text)


def build_parser() -> argparse.ArgumentParser:
    """The command line's argument parser."""
    defaults = QLearningConfig()
    parser = ArgumentParser(
        prog=PROG,
        description="Train tabular Q-learning on the warehouse robot, save, plot and evaluate.",
    )
    # No default here: with --eval the table's own environment is the default.
    add_env_argument(parser, default=None, note=", or with --eval the table's own")
    parser.add_argument(
        "--episodes",
        type=bounded_int(1, "a positive number of episodes"),
        help=f"training episodes (default {defaults.episodes}, or the layout preset's own; "
        f"{FLEET_EPISODES} for a fleet)",
    )
    parser.add_argument(
        "--seed",
        type=bounded_int(0, "a non-negative integer seed"),
        default=defaults.seed,
        help=f"seed of the environment and the agent (default {defaults.seed})",
    )
    add_floor_arguments(parser, table_note="; with --eval it must match the table")
    add_robots_argument(
        parser,
        what="train a fleet of this many robots on one floor, sharing one table and "
        "the traffic rule (see warehouse_phys.envs.fleet)",
    )
    parser.add_argument(
        "--observation",
        choices=("local", "neighbours"),
        default=None,
        help="with --robots 2 or more: a fleet's shared table reads each robot's own cell "
        "and package (local, the default), or those and which adjacent cells hold a robot "
        "(neighbours: a table 16 times larger, with which robots learn to step aside)",
    )
    parser.add_argument(
        "--alpha",
        type=_fraction(low_open=True),
        default=defaults.alpha,
        help=f"learning rate in (0, 1] (default {defaults.alpha})",
    )
    parser.add_argument(
        "--gamma",
        type=_fraction(low_open=False),
        default=defaults.gamma,
        help=f"discount factor in [0, 1] (default {defaults.gamma})",
    )
    parser.add_argument(
        "--out",
        type=_folder,
        help="run folder to write (default runs/<env>-seed<seed>-<time>)",
    )
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="let --out name a folder that holds an earlier run, whose files are replaced",
    )
    parser.add_argument(
        "--render",
        action="store_true",
        help="afterwards, watch one greedy episode in a window",
    )
    parser.add_argument(
        "--eval",
        type=Path,
        metavar="PATH",
        help="evaluate the table saved at PATH instead of training",
    )
    parser.add_argument(
        "--no-gif",
        dest="gif",
        action="store_false",
        help=f"do not write {GIF_FILE}, the animated greedy episode, into the run folder",
    )
    parser.add_argument(
        "--quiet", action="store_true", help="print nothing on success, show no progress bar"
    )
    return parser


@stops_on_sigterm
@warnings_in_one_line(PROG)
def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status (130 on Ctrl-C, 143 on SIGTERM)."""
    run: list[RunFolder] = []  # the run folder, once there is one
    try:
        args = build_parser().parse_args(argv)
        if args.eval is not None:
            refuse_training_options(args)
            return evaluate_saved(args)
        return _train(args, run)
    except (UsageError, RunFolderError) as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return 2
    except (RunWriteError, NoDisplayError) as error:
        print(f"{PROG}: error: {error}{_written(run)}", file=sys.stderr)
        return 1
    except KeyboardInterrupt as interrupt:  # Ctrl-C, or SIGTERM as a Terminated
        stopped, status = interruption(interrupt)
        print(f"{PROG}: {stopped}; {_written(run, interrupted=True)}", file=sys.stderr)
        return status


def _written(run: list[RunFolder], *, interrupted: bool = False) -> str:
    """What the run wrote, for the message of a run that stopped early."""
    folder = run[0] if run else None
    if folder is None or not folder.written:
        return "nothing was written" if interrupted else ""
    names = ", ".join(folder.written)
    text = f"{names} {'is' if len(folder.written) == 1 else 'are'} complete in {folder.path}"
    return text if interrupted else f" ({text})"


# ----------------------------------------------------------------- training
def _train(args: argparse.Namespace, run: list[RunFolder]) -> int:
    kind = args.env or DEFAULT_ENV
    floor = floor_from_args(args)
    episodes = args.episodes
    if args.robots > 1:
        return _train_fleet(args, run, kind, floor)
    if args.observation is not None:
        raise UsageError(
            "--observation chooses what a fleet's robots see; it needs --robots 2 or more"
        )
    if episodes is None:
        episodes = PRESETS[floor.preset].training_episodes if floor.preset else 1000
    config = QLearningConfig(episodes=episodes, alpha=args.alpha, gamma=args.gamma, seed=args.seed)
    env_id = floor.env_id(kind)
    grid = floor.grid()
    rows, cols = grid.rows, grid.cols
    try:
        check_training_memory(rows, cols, config.episodes)
    except ValueError as error:
        raise UsageError(str(error)) from None
    if args.render:
        check_display()  # before training, not after it

    folder, outcome = _in_run_folder(
        args, run, kind, floor.label, config.episodes, env_id,
        lambda folder, on_episode: train_run(
            folder, floor, kind, config, gif=args.gif, on_episode=on_episode
        ),
    )  # fmt: skip
    result, evaluation, seconds = outcome.result, outcome.evaluation, outcome.seconds
    run_dir = folder.path
    if not args.quiet:
        print(
            f"trained {config.episodes} episodes on {env_id} ({rows}x{cols}) in {seconds:.2f} s; "
            f"{int(result.reached_target.sum())} reached the target, "
            f"{int(result.truncated.sum())} were truncated at "
            f"{outcome.max_episode_steps} steps"
        )
        print(evaluation.table())
        hint = _advice(evaluation, config, outcome.max_episode_steps)
        if hint:
            print(hint)
        written = [CURVE_FILE, *([GIF_FILE] if outcome.gif_written else []), SUMMARY_FILE]
        print(f"wrote {run_dir / TABLE_FILE}, {', '.join(written[:-1])} and {written[-1]}")
    if args.render:
        watch(floor, kind, result.q, seed=args.seed)
    return 0


def _train_fleet(args: argparse.Namespace, run: list[RunFolder], kind: str, floor: Floor) -> int:
    """``--robots N``: a fleet sharing one table, evaluated beside the shortest-path
    policy, random and the planner."""
    robots = args.robots
    if args.render:
        raise UsageError("--render shows one robot in a window; leave it out with --robots")
    args.observation = args.observation or "local"
    config = QLearningConfig(
        episodes=args.episodes or FLEET_EPISODES, alpha=args.alpha, gamma=args.gamma, seed=args.seed
    )
    try:
        floor.make_fleet(kind, robots).close()  # a floor too small for the fleet: say so now
        grid = floor.grid()
        tail = table_tail({"robots": robots, "observation": args.observation})
        check_training_memory(grid.rows, grid.cols, config.episodes, tail=tail)
    except ValueError as error:
        hint = "; --env grid takes more" if kind == "phys" and robots > MAX_PHYSICS_ROBOTS else ""
        raise UsageError(f"{error}{hint}") from None
    label = f"{floor.label or ''}{'-' if floor.label else ''}{robots}robots"
    folder, outcome = _in_run_folder(
        args, run, kind, label, config.episodes, f"{robots} robots",
        lambda folder, on_episode: train_fleet_run(
            folder, floor, kind, robots, config, gif=args.gif, on_episode=on_episode,
            observation=args.observation,
        ),
    )  # fmt: skip
    if not args.quiet:
        result = outcome.result
        print(
            f"trained {robots} robots sharing one table for {config.episodes} episodes on "
            f"{outcome.env_id} in {outcome.seconds:.2f} s; every package delivered in "
            f"{int(result.reached_target.sum())} episodes, {int(result.truncated.sum())} cut at "
            f"{outcome.summary['training']['max_steps']} steps"
        )
        print(f"evaluated over {len(EVALUATION_SEEDS)} seeds, one package per robot:")
        print(compare_policies(outcome.comparison))
        written = [CURVE_FILE, *([GIF_FILE] if outcome.gif_written else []), SUMMARY_FILE]
        print(f"wrote {folder.path / TABLE_FILE}, {', '.join(written[:-1])} and {written[-1]}")
    return 0


def _in_run_folder(
    args: argparse.Namespace,
    run: list[RunFolder],
    kind: str,
    label: str | None,
    episodes: int,
    description: str,
    work: Callable[[RunFolder, Callable[[int], None]], Outcome],
) -> tuple[RunFolder, Outcome]:
    """Open the run's folder (a new one, or ``--out``), do ``work(folder, on_episode)``
    with a progress bar over ``episodes``, and close the folder (removing it if the
    work did not finish and wrote nothing)."""
    new = _new_run_dir(kind, label, args.seed, time.localtime())  # unless --out names one
    with opened_run_folder(args.out, new, RUN_FILES, overwrite=args.overwrite) as folder:
        run.append(folder)
        progress = _progress_bar(episodes, description, disable=args.quiet)
        try:
            outcome = work(folder, lambda _: progress.update())
        finally:
            progress.close()
    return folder, outcome


def _advice(evaluation: Evaluation, config: QLearningConfig, max_steps: int) -> str | None:
    """One line on what to try when the greedy policy is not optimal everywhere."""
    if evaluation.all_optimal:
        return None
    total = len(evaluation.results)
    missed = total - evaluation.reached
    what = (
        f"the greedy policy misses {missed} of {total} targets"
        if missed
        else f"the greedy policy takes a longer path to {total - evaluation.optimal} of "
        f"{total} targets"
    )
    return (
        f"{what}: try more episodes (--episodes {config.episodes * 4}) or a longer time "
        f"limit (--max-steps {max_steps * 2})"
    )


def _new_run_dir(kind: str, label: str | None, seed: int, started: time.struct_time) -> Path:
    """``runs/<env>[-<layout>]-seed<seed>-<time>``, with a suffix if that folder exists."""
    floor = f"-{label}" if label else ""
    name = f"{kind}{floor}-seed{seed}-{time.strftime('%Y%m%d-%H%M%S', started)}"
    run_dir, n = DEFAULT_RUNS_DIR / name, 1
    while run_dir.exists():
        n += 1
        run_dir = DEFAULT_RUNS_DIR / f"{name}-{n}"
    return run_dir


def _progress_bar(episodes: int, env_id: str, *, disable: bool) -> Any:
    from tqdm import tqdm

    # disable=None: tqdm switches itself off when stderr is not a terminal.
    return tqdm(
        total=episodes,
        desc=f"training on {env_id}",
        unit="episode",
        disable=True if disable else None,
        file=sys.stderr,
    )


if __name__ == "__main__":
    sys.exit(main())
