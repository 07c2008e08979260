"""``python -m warehouse_phys.simulate``: run a fleet policy on a floor and measure it.

::

    python -m warehouse_phys.simulate --layout kiva-33-46 --robots 192
    python -m warehouse_phys.simulate --layout warehouse --robots 128 --policy shortest
    python -m warehouse_phys.simulate --layout aisles --robots 4 --on-delivery park \\
        --policy runs/grid-aisles-seed0-.../qtable.npz
    python -m warehouse_phys.simulate --moves rotate \\
        --instance lorr-example/random-64-64-10-seed0-400.json

(the last, an instance drawn by :func:`~warehouse_phys.lorr.generator.make_instance` on
the shipped map ``random-64-64-10-seed0`` and written by
:func:`~warehouse_phys.lorr.instances.write_instance` into ``lorr-example/``). A fleet
of ``--robots`` robots on ``--layout`` (a preset, a shipped benchmark map's name, a
``.map`` file or a text layout file; or ``--rows``/``--cols``) follows ``--policy`` for
``--steps`` joint steps: a planner of :data:`~warehouse_phys.rl.fleet_planners.PLANNERS` by its name
(``pibt``, the planner of :mod:`warehouse_phys.planners.pibt`, by default; ``guided`` and
its ablations, whose fields ``--guidance '{"reroute": 32}'`` sets; those of
:data:`~warehouse_phys.rl.fleet_planners.TURNING_ONLY` for
turning robots), ``shortest`` (each
robot a shortest move, waiting when blocked), ``random``, or a fleet table written by
``python -m warehouse_phys.train --robots N``. ``--on-delivery``
(default ``new_package``: lifelong) says what a robot does with a delivered
package; ``--physics`` drives the physics twin. The command prints the throughput
(deliveries per step), deliveries, waits and refused moves (one-shot, also the
packages delivered, the makespan, the sum of costs against the shortest paths' and
the packages walled off); when it is cheap (robots x steps at most
:data:`~warehouse_phys.apps.simulate.lockstep.COMPARE_BUDGET` on the grid;
``--no-compare`` skips it) it runs the shortest-path and random baselines on the same
floor, seed and steps and names a policy that does worse. It writes a run folder (default
``runs/simulate-<floor>-<robots>-<policy>-seed<seed>-<time>``): ``summary.json``
(with the comparison), ``throughput.png`` (deliveries over time), ``congestion.png``
(waits on each cell) and ``fleet.gif`` (``--frames`` frames evenly spread, sized to
fit a 1000-pixel frame). Bad arguments end with exit status 2 and a one-line message.

``--instance X.json`` runs a League of Robot Runners problem instead
(:mod:`warehouse_phys.lorr.instances`: its floor, robots, starts and task list;
``--steps`` 5,000 by default, as the competition counts): it reports errands and
tasks finished a step, beside the published figure where the instance is one of
:data:`~warehouse_phys.lorr.instances.PUBLISHED_FIGURES`, and also writes
``lorr-output.json``, the competition's output file
(:mod:`warehouse_phys.lorr.output`), which its own tools and viewer read.
``--moves rotate`` gives the robots the competition's model (turn in place, drive
forward), on any floor.

**Ticks and delays** (League of Robot Runners 2026): an instance that names
``agentCounter`` or ``delayConfig``, or ``--ticks-per-move N`` / ``--p-delay P``
(``--delay-seed S``) on any instance or floor, runs the asynchronous fleet instead: moves
take ticks, robots are delayed at random, an executor keeps them apart, and ``--steps``
counts ticks (an instance's 5,000 by default, as LoRR 2026 counts; a floor's 256 moves'
worth). It reports errands and tasks a tick and a move-duration, the robot-ticks stood
still by own and knock-on delays and the mean drift; its ``lorr-output.json`` adds
``agentMaxCounter`` and ``delayIntervals``. ``--moves rotate`` turns LoRR's robots on
ticks too: :mod:`warehouse_phys.apps.simulate.on_ticks` has the details.

``summary.json`` records the CPU time of the reset, of the first step and the median and
slowest of the others (frames apart), and of the frames.
SIGTERM stops it as Ctrl-C does (exit status 143).

The command line is this module: its options, its checks and its messages. It runs one of
two modes, each a module, over what both share (no mode imports the other):
:mod:`~warehouse_phys.apps.simulate.lockstep` (:func:`simulate`, the baselines),
:mod:`~warehouse_phys.apps.simulate.on_ticks` (the run on ticks) and
:mod:`~warehouse_phys.apps.simulate.results` (the :class:`Simulation` record, the
policies by name, the run folder's files).
"""

from __future__ import annotations

from warehouse_phys._starting import command_interrupts

# python -m warehouse_phys.apps.<app> imports this package before its __main__: Ctrl-C
# while it imports is the command's one line, as with the short name's.
with command_interrupts():
    import argparse
    import dataclasses
    import functools
    import gc
    import sys
    import time
    from pathlib import Path
    from typing import Any

    import numpy as np

    from warehouse_phys.apps.cli import (
        MAX_CLI_ROBOTS,
        ArgumentParser,
        UsageError,
        add_guidance_argument,
        bounded_int,
        floor_from_layout,
        opened_run_folder,
        warnings_in_one_line,
        written_note,
    )
    from warehouse_phys.apps.interrupts import interruption, stops_on_sigterm
    from warehouse_phys.apps.simulate.lockstep import (
        BASELINES,
        COMPARE_BUDGET,
        comparison_table,
        run_baselines,
        simulate,
    )
    from warehouse_phys.apps.simulate.on_kit import (
        add_kit_arguments,
        kit_rules,
        kit_system,
        simulate_kit,
        write_kit_output,
    )
    from warehouse_phys.apps.simulate.on_ticks import (
        add_tick_arguments,
        default_ticks,
        simulate_ticks,
        tick_fleet,
        tick_options,
    )
    from warehouse_phys.apps.simulate.results import (
        BASELINE_POLICIES,
        DEFAULT_STEPS,
        INSTANCE_STEPS,
        POLICIES,
        RUN_FILES,
        Simulation,
        make_policy,
        write_lorr_output,
        write_run_files,
    )
    from warehouse_phys.envs.fleet import WarehouseFleetEnv, parallel_env
    from warehouse_phys.envs.fleet.setup import DELIVERY_MODES
    from warehouse_phys.lorr.instances import SCHEDULED, read_instance
    from warehouse_phys.lorr.output import RunRecord
    from warehouse_phys.lorr.scheduling_assignment import SCHEDULER_NAMES, scheduler_for
    from warehouse_phys.lorr.startkit.system import KitSystem
    from warehouse_phys.lorr.station_cap import STATION_CAP
    from warehouse_phys.rl.fleet_evaluation import FleetPolicy
    from warehouse_phys.rl.fleet_planners import PLANNERS, planner_policy
    from warehouse_phys.world.headings import MOVE_MODELS
    from warehouse_phys.world.layouts import FLEET_PRESETS, PRESETS
    from warehouse_phys.world.maps import MAPS

#: The command's names, its own and those its modes' modules define: all import from here.
__all__ = [
    "BASELINES",
    "COMPARE_BUDGET",
    "DEFAULT_FRAMES",
    "DEFAULT_RUNS_DIR",
    "DEFAULT_STEPS",
    "INSTANCE_STEPS",
    "POLICIES",
    "PROG",
    "RUN_FILES",
    "Simulation",
    "build_parser",
    "comparison_table",
    "main",
    "make_policy",
    "run_baselines",
    "simulate",
]

PROG = "python -m warehouse_phys.simulate"
#: Most steps (or ticks) a run may last: as many as a fleet's ``max_cycles``.
MAX_STEPS = 10**9
DEFAULT_RUNS_DIR = Path("runs")
#: Frames of the GIF by default: enough to see the traffic, few enough to stay small.
DEFAULT_FRAMES = 64


def build_parser() -> argparse.ArgumentParser:
    parser = ArgumentParser(
        prog=PROG,
        description="Run a fleet policy on a floor; print and save its throughput.",
    )
    parser.add_argument(
        "--layout",
        help=f"a preset, a benchmark map the package ships ({', '.join(MAPS)}), a MovingAI "
        ".map file or a layout file",
    )
    parser.add_argument(
        "--instance", type=Path,
        help="a League of Robot Runners instance (.json): its floor, robots and tasks (one "
        "naming agentCounter or delayConfig runs on ticks)",
    )  # fmt: skip
    parser.add_argument(
        "--moves", choices=MOVE_MODELS,
        help="grid: four directions (a floor's default); rotate: robots turn in place and "
        "drive forward (an instance's default, the competition's robots)",
    )  # fmt: skip
    parser.add_argument(
        "--scheduler", choices=SCHEDULER_NAMES,
        help="which free robot takes which task, on a 2024 or later instance: rematch (a "
        "minimum-cost assignment on true distances, robots on their way to a task not "
        "opened yet paired again, default), rematch-capped (the same, at most "
        f"{STATION_CAP} robots on their way to one station), rematch-backlog (that cap, grown "
        "at a station with more open tasks than the mean), assignment (the same without "
        "pairing again), "
        "nearest (the first stop nearest the robot) or makespan (the least distance to the "
        "first stop plus the task's own length, as the competition's default entry)",
    )  # fmt: skip
    parser.add_argument("--rows", type=bounded_int(2, "at least 2 rows"), help="empty floor rows")
    parser.add_argument("--cols", type=bounded_int(2, "at least 2 columns"), help="columns")
    parser.add_argument(
        "--robots",
        type=bounded_int(1, f"a number of robots from 1 to {MAX_CLI_ROBOTS:,}", MAX_CLI_ROBOTS),
        help="robots in the fleet (default 4; an instance: its teamSize)",
    )
    parser.add_argument(
        "--policy",
        default="pibt",
        help=f"a planner: {', '.join(PLANNERS)} (pibt by default; guided: PIBT following "
        "traffic-priced guide paths; *-ops, *-repair: turning robots only, --moves rotate); "
        f"a baseline: {', '.join(BASELINE_POLICIES)}; or a fleet table (.npz) from train",
    )
    add_guidance_argument(parser)
    parser.add_argument(
        "--steps", type=bounded_int(1, f"a number of steps from 1 to {MAX_STEPS:,}", MAX_STEPS),
        help=f"joint steps (default {DEFAULT_STEPS}; an instance: {INSTANCE_STEPS:,}); on "
        f"ticks: ticks (default: an instance's {INSTANCE_STEPS:,}, as LoRR 2026 counts; a "
        f"floor's {DEFAULT_STEPS} moves' worth)",
    )  # fmt: skip
    parser.add_argument(
        "--on-delivery", choices=DELIVERY_MODES,
        help="what a robot does with a delivered package (default new_package: lifelong)",
    )  # fmt: skip
    parser.add_argument("--physics", action="store_true", help="drive the physics twin")
    parser.add_argument(
        "--physics-threads", metavar="K", type=bounded_int(1, "threads from 1 to 64", 64),
        default=1,
        help="with --physics: hold the bodies in K regions of the floor stepped in parallel "
        "(the same bodies for a seed and K; default 1)",
    )  # fmt: skip
    add_tick_arguments(parser)
    add_kit_arguments(parser)
    parser.add_argument("--seed", type=bounded_int(0, "a seed of 0 or more"), default=0)
    parser.add_argument(
        "--frames", type=bounded_int(0, "a number of frames of 0 or more"),
        default=DEFAULT_FRAMES, help=f"GIF frames (default {DEFAULT_FRAMES}; 0: no GIF)",
    )  # fmt: skip
    parser.add_argument("--out", type=Path, help="run folder to write")
    parser.add_argument(
        "--overwrite", action="store_true", help="reuse --out holding an earlier run's files"
    )
    parser.add_argument(
        "--no-compare", action="store_true",
        help=f"never run the baselines ({', '.join(BASELINES)}); they run by default when "
        f"robots x steps is at most {COMPARE_BUDGET:,} on the grid",
    )  # fmt: skip
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    return parser


@stops_on_sigterm
@warnings_in_one_line(PROG)
def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status: 0, 2 for a bad command line, 1 when
    a file cannot be written, 130 on Ctrl-C and 143 on SIGTERM (saying what was written;
    a new run folder left empty is removed)."""
    from warehouse_phys.files.runfolder import RunFolderError, RunWriteError

    folder = None
    try:
        args = build_parser().parse_args(argv)
        env, policy = _setup(args)
        label = _floor_label(args)
        name = (
            f"simulate-{label}-{env.num_robots}-{Path(args.policy).stem}-seed{args.seed}-"
            f"{time.strftime('%Y%m%d-%H%M%S')}"
        )
        new = DEFAULT_RUNS_DIR / name
        with opened_run_folder(args.out, new, RUN_FILES, overwrite=args.overwrite) as folder:
            result, frames, record = _run(args, env, policy, label)
            if record is not None:  # before the baselines run the errand list again
                write_lorr_output(folder, env, result, record)
            elif isinstance(env, KitSystem):  # its own output file: the kit's 2026 one
                write_kit_output(folder, env)
            runs = {result.policy: result}
            if _compare(args, env):
                runs |= run_baselines(env, steps=args.steps, seed=args.seed, skip=result.policy)
            write_run_files(folder, env, result, frames, runs)
    except (UsageError, RunFolderError) as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return 2
    except RunWriteError as error:  # a full disk, say: which files are whole
        print(f"{PROG}: error: {error} ({written_note(folder)})", file=sys.stderr)
        return 1
    except KeyboardInterrupt as interrupt:
        stopped, status = interruption(interrupt)
        print(f"{PROG}: {stopped}; {written_note(folder)}", file=sys.stderr)
        return status
    print(result.summary())
    if result.safety_measures() is not None:
        print(result.safety_measures())
    for note in result.not_simulated:
        print(f"not simulated: {note}")
    if len(runs) > 1:
        print("against the baselines, on the same floor, seed and steps:")
        print(comparison_table(runs))
    print(f"wrote {folder.path}/: {', '.join(folder.written)}")
    return 0


def _setup(args: argparse.Namespace) -> tuple[Any, FleetPolicy | None]:
    """The fleet and its policy that the command line asks for: the asynchronous fleet
    and no policy for a run on ticks (:mod:`warehouse_phys.apps.simulate.on_ticks`).

    Raises:
        UsageError: one line, for arguments that do not go together or that the fleet
            refuses, or an instance file that cannot be read.
    """
    if args.layout is not None and (args.rows is not None or args.cols is not None):
        raise UsageError("give --layout or --rows/--cols, not both")
    if args.scheduler is not None and args.instance is None:
        raise UsageError("--scheduler hands out an instance's tasks: give --instance")
    if args.physics_threads != 1 and not args.physics:
        raise UsageError("--physics-threads steps the physics twin's bodies: give --physics")
    if args.guidance:
        _check_guidance(args.policy, args.guidance)
    instance = None
    args.moves = args.moves or ("grid" if args.instance is None else "rotate")
    if args.instance is not None:
        given = [flag for flag, value in (("--layout", args.layout), ("--rows", args.rows),
                 ("--cols", args.cols), ("--robots", args.robots),
                 ("--on-delivery", args.on_delivery)) if value is not None]  # fmt: skip
        if given:
            raise UsageError(f"an instance gives the floor, the robots and their errands; "
                             f"do not give {', '.join(given)}")  # fmt: skip
        try:
            instance = read_instance(args.instance)
        except (ValueError, TypeError, OSError) as error:
            raise UsageError(str(error).splitlines()[0]) from None
        floor: dict[str, Any] = {"instance": instance, "record_errands": True}
        if args.scheduler is not None and instance.assignment != SCHEDULED:
            raise UsageError(
                f"--scheduler: {instance.name} assigns its tasks {instance.assignment!r} "
                "(LoRR 2023), without a scheduler"
            )
        if args.scheduler is not None:
            floor["scheduler"] = scheduler_for(args.scheduler, instance.grid)
    elif args.layout is None:
        floor = {"grid_rows": args.rows or 4, "grid_cols": args.cols or 5}
    else:
        floor = {"layout": _fleet_layout(args.layout)}
    ticks = tick_options(args, instance)
    if args.steps is None and ticks is not None:
        args.steps = default_ticks(instance, ticks)
    elif args.steps is None:
        args.steps = DEFAULT_STEPS if instance is None else INSTANCE_STEPS
    if args.instance is None:
        floor |= {"num_robots": args.robots or 4, "on_delivery": args.on_delivery or "new_package"}
    if kit_rules(instance, ticks is not None, args.moves, args.physics):
        return kit_system(
            instance,
            ticks,
            policy=args.policy,
            scheduler=args.scheduler,
            seed=args.seed,
            delays_from=args.delays_from,
            ticks=args.steps,
            guidance=args.guidance,
        ), None
    if args.delays_from is not None:
        raise UsageError(
            "--delays-from replays a start-kit run's delays by the kit's rules: an "
            "instance on ticks, turning robots (--moves rotate), no --physics"
        )
    try:
        if ticks is not None:
            return tick_fleet(floor, ticks, ticks=args.steps, physics=args.physics,
                              seed=args.seed, moves=args.moves, planner=args.policy,
                              guidance=args.guidance,
                              physics_threads=args.physics_threads), None  # fmt: skip
        bodies = {"physics_threads": args.physics_threads, "track_gaps": False}  # safety measures
        env = parallel_env(
            physics=args.physics, max_cycles=args.steps, moves=args.moves,
            observation=_observation_of(args.policy), **floor, **(bodies if args.physics else {}),
        )  # fmt: skip
        policy = make_policy(args.policy, env, seed=args.seed, guidance=args.guidance)
    except (ValueError, TypeError, OSError) as error:
        raise UsageError(str(error).splitlines()[0]) from None
    return env, policy


def _check_guidance(policy: str, guidance: dict[str, Any]) -> None:
    """Refuse ``--guidance`` for a policy with no guidance, or fields its planner refuses.

    Raises:
        UsageError: one line, naming ``--guidance``.
    """
    if policy not in PLANNERS or policy == "pibt":
        raise UsageError(f"--guidance sets a guided planner's fields; --policy {policy} has none")
    try:
        planner_policy(policy, **guidance)
    except (TypeError, ValueError) as error:
        raise UsageError(f"--guidance: {error}") from None


def _fleet_layout(name: str) -> str | tuple[str, ...]:
    """The fleet's ``layout=`` for ``--layout name``: a preset's name, a shipped map's name
    or a map's path as given (the fleet reads them), else a layout text file's rows, read
    as train, play and sweep read them.

    Raises:
        UsageError: for a name that is neither a preset nor a file, or a file that is not
            a layout.
    """
    if name in PRESETS or name in FLEET_PRESETS or name in MAPS or name.endswith(".map"):
        return name
    rows = floor_from_layout(name).layout
    return name if rows is None else rows


def _compare(args: argparse.Namespace, env: Any) -> bool:
    """Whether the baselines run too: unless --no-compare, on the grid, in lock step, when
    cheap."""
    cheap = env.num_robots * args.steps <= COMPARE_BUDGET
    lock_step = isinstance(env, WarehouseFleetEnv)
    return not args.no_compare and not args.physics and lock_step and cheap


def _observation_of(policy: str) -> str:
    """The observation a table was trained on (its shape says), else ``"local"``."""
    if not policy.endswith(".npz"):
        return "local"
    from warehouse_phys.rl.qlearning import QTableError, load_q_table

    try:
        q, _ = load_q_table(policy)
    except (QTableError, OSError) as error:
        raise ValueError(f"--policy {error}") from None
    return "neighbours" if q.ndim == 6 else "local"


def _floor_label(args: argparse.Namespace) -> str:
    if args.instance is not None:
        return Path(args.instance).stem
    if args.layout is None:
        return f"{args.rows or 4}x{args.cols or 5}"
    return Path(args.layout).stem  # a preset's name, a map's or a layout file's stem


def _run(
    args: argparse.Namespace, env: Any, policy: FleetPolicy | None, label: str
) -> tuple[Simulation, list[np.ndarray], RunRecord | None]:
    """Run ``policy`` on ``env`` (a run on ticks: no policy) as the command line says,
    with a progress bar; returns the measures, the frames and an instance's record."""
    from tqdm import tqdm

    if isinstance(env, KitSystem):  # by the start kit's rules: it keeps its own output
        play, turning, unit = functools.partial(simulate_kit, env), True, "tick"
    elif policy is None:  # on ticks
        play, turning, unit = functools.partial(simulate_ticks, env), env.turning, "tick"
    else:
        play, turning, unit = functools.partial(simulate, env, policy), env.turning, "step"
    record = None
    if env.instance is not None and not isinstance(env, KitSystem):
        record = RunRecord(env.num_robots, turning=turning)
    # The floor's and the fleet's long-lived objects (tens of thousands of cells on a large
    # map) leave Python's full collections, which otherwise walk them and stall a step.
    gc.freeze()
    # disable=None: tqdm switches itself off when stderr is not a terminal.
    with tqdm(total=args.steps, desc="simulating", unit=unit,
              disable=True if args.quiet else None) as bar:  # fmt: skip
        try:
            result, frames = play(
                steps=args.steps, seed=args.seed, frames=args.frames, on_step=bar.update,
                name=Path(args.policy).name, layout=label, record=record,
            )  # fmt: skip
        except ValueError as error:  # a table's observation that does not fit, ...
            raise UsageError(str(error).splitlines()[0]) from None
        finally:
            gc.unfreeze()
    if args.guidance:  # recorded in summary.json beside the planner's name
        result = dataclasses.replace(result, guidance=args.guidance)
    return result, frames, record


if __name__ == "__main__":
    sys.exit(main())
