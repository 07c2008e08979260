"""``python -m warehouse_phys.startkit``: the package as a League of Robot Runners start-kit entry.

::

    python -m warehouse_phys.startkit install ../start-kit
    python -m warehouse_phys.startkit build --kit ../shared/lorr/start-kit-3.1.0
    python -m warehouse_phys.startkit run ../shared/lorr/2026-examples-maze/maze-example_40.json \\
        --kit ../shared/lorr/start-kit-3.1.0 --ticks 600 --out runs/startkit-maze

``install KIT_DIR`` writes the kit's three Python components
(``python/user_planner/pyMAPFPlanner.py``, ``python/user_scheduler/pyTaskScheduler.py``,
``python/user_executor/pyExecutor.py``) into a start-kit checkout; they load this package
(:mod:`warehouse_phys.lorr.startkit.install`). Then the kit's own ``./build/lifelong -i
INSTANCE.json --plannerPython true --schedulerPython true --executorPython true`` runs the
entry. A component there that this package did not write is kept unless ``--force``.

``build --kit KIT_DIR`` builds the kit for this interpreter into its cache folder (once;
it prints the folder), as ``run`` does when it must.

``run INSTANCE.json --kit KIT_DIR --ticks N --out DIR`` builds the kit if it is not built
yet (into a cache folder outside any checkout, once per kit and interpreter:
:mod:`warehouse_phys.lorr.startkit.build`), then runs, in one go, on the same instance:
the kit with the entry (``DIR/ours.json``, its log ``DIR/ours.log``), the kit's default
entry (``DIR/default.json``) and ``python -m warehouse_phys.simulate`` by the kit's rules
with the delays of the first (``DIR/simulate/``), and writes ``DIR/summary.json``. It
prints one table: tasks finished, the motions the kit's action model refused, planner and
schedule errors, the checks that found the planner late and the ticks every robot waited
for a late executor, wall and CPU time (each run's own process). ``--only`` runs one of
the three, beside the runs of the same setting already in ``DIR`` (``--only ours``, then
``--only simulate`` on its delays); a run already there is replaced only with
``--overwrite``, and ``DIR`` never holds runs of two settings
(:mod:`warehouse_phys.lorr.startkit.run_folder`); ``DIR`` is locked while the command runs
(:func:`~warehouse_phys.files.runfolder.lock_folder`), so a second command into it is
refused at once. ``--planner``, ``--scheduler`` and
``--guidance`` (the planner's fields, a JSON object) set the entry's (by default what
``WAREHOUSE_PHYS_PLANNER``, ``WAREHOUSE_PHYS_SCHEDULER`` and ``WAREHOUSE_PHYS_GUIDANCE``
say, else ``guided-ops-repair``, ``assignment`` and ``{}``), and ``simulate`` runs the same
ones (``assignment`` is its ``rematch``, ``assignment-capped`` its ``rematch-capped``,
``assignment-backlog`` its ``rematch-backlog``); ``WAREHOUSE_PHYS_ROUND_SHARE`` sets the
share of the kit's time limit the entry's round aims at (0.6; ``none``: no bound, the
plans ``simulate`` makes), recorded with the setting. Exit
status: 0; 2 for a bad command line or instance; 1 when the kit cannot be built or run
(one line saying what is missing, or where its log is).
"""

from __future__ import annotations

from warehouse_phys._starting import command_interrupts

# python -m warehouse_phys.apps.<app> runs this module as __main__: Ctrl-C while it
# imports is the command's one line, as with the short name's.
with command_interrupts(__name__ == "__main__"):
    import argparse
    import json
    import os
    import sys
    from pathlib import Path
    from typing import Any

    from warehouse_phys.apps.cli import ArgumentParser, UsageError, bounded_int, guidance_fields
    from warehouse_phys.files.atomic import atomic_write_text
    from warehouse_phys.files.runfolder import (
        RunFolderError,
        RunWriteError,
        lock_folder,
        make_folders,
        remove_empty,
    )
    from warehouse_phys.lorr.instances import LorrInstance, read_instance
    from warehouse_phys.lorr.startkit.build import KitBuildError, NotAKitError, build_kit
    from warehouse_phys.lorr.startkit.install import InstallError, install
    from warehouse_phys.lorr.startkit.planner import entry_planner
    from warehouse_phys.lorr.startkit.run_folder import SUMMARY, RunFolderRefused, prepare_folder
    from warehouse_phys.lorr.startkit.runs import RUNS, comparison_table, run_kit, run_simulate
    from warehouse_phys.lorr.startkit.scheduler import ENTRY_SCHEDULERS, FLEET_SCHEDULERS
    from warehouse_phys.lorr.startkit.settings import entry_guidance, round_share, setting, shown
    from warehouse_phys.planners.named import PLANNERS
    from warehouse_phys.world.grid import WarehouseGrid

PROG = "python -m warehouse_phys.startkit"


def build_parser() -> argparse.ArgumentParser:
    parser = ArgumentParser(prog=PROG, description="The package as a League of Robot Runners "
                            "start-kit entry: install it into a kit, or run it beside the kit's "
                            "default entry and the package's own simulation.")  # fmt: skip
    commands = parser.add_subparsers(dest="command", required=True, parser_class=ArgumentParser)
    put = commands.add_parser("install", help="write the kit's three python/user_*/ files")
    put.add_argument("kit", type=Path, metavar="KIT_DIR", help="a start-kit checkout")
    put.add_argument("--force", action="store_true",
                     help="replace components that this package did not write")  # fmt: skip
    make = commands.add_parser("build", help="build the kit into its cache folder (once)")
    make.add_argument("--kit", type=Path, required=True, metavar="KIT_DIR",
                      help="the start kit's source (only read)")  # fmt: skip
    make.add_argument("--jobs", type=bounded_int(1, "a positive number of jobs"), default=2,
                      help="make's jobs (default 2)")  # fmt: skip
    run = commands.add_parser("run", help="run the entry, the kit's default entry and simulate")
    run.add_argument("instance", type=Path, metavar="INSTANCE.json")
    run.add_argument(
        "--kit",
        type=Path,
        required=True,
        metavar="KIT_DIR",
        help="the start kit's source (only read; built into a cache folder)",
    )
    run.add_argument("--ticks", type=bounded_int(1, "a positive number of ticks"), required=True)
    run.add_argument("--out", type=Path, required=True, metavar="DIR", help="folder to write")
    run.add_argument("--only", choices=RUNS,
                     help="run only this one, beside DIR's runs of the same setting")  # fmt: skip
    run.add_argument("--overwrite", action="store_true",
                     help="replace an earlier run in DIR (with --only: that run alone, if the "
                     "setting is the same)")  # fmt: skip
    run.add_argument("--jobs", type=bounded_int(1, "a positive number of jobs"), default=2,
                     help="make's jobs when the kit is built (default 2)")  # fmt: skip
    run.add_argument("--planner", choices=PLANNERS,
                     help="the entry's planner, and simulate's (default: WAREHOUSE_PHYS_PLANNER, "
                     "else guided-ops-repair)")  # fmt: skip
    run.add_argument("--scheduler", choices=ENTRY_SCHEDULERS,
                     help="the entry's scheduler, and simulate's (default: "
                     "WAREHOUSE_PHYS_SCHEDULER, else assignment; assignment-capped sends at "
                     "most 8 robots to one station; assignment-backlog more to a station "
                     "with more open tasks than the mean)")  # fmt: skip
    run.add_argument("--guidance", type=guidance_fields, metavar="JSON",
                     help="the entry's planner's fields, and simulate's, a JSON object such as "
                     "'{\"reroute\": 32}' (default: WAREHOUSE_PHYS_GUIDANCE, else {})")  # fmt: skip
    return parser


def _entry(args: argparse.Namespace) -> tuple[str, str, dict[str, Any], float | None]:
    """The entry's planner, scheduler and planner's fields (the command line's, else the
    environment's) and its round's share of the kit's time limit (the environment's).

    Raises:
        UsageError: for a planner or scheduler the environment names that the entry has
            not, or fields its planner refuses.
    """
    planner = args.planner or setting("WAREHOUSE_PHYS_PLANNER")
    scheduler = args.scheduler or setting("WAREHOUSE_PHYS_SCHEDULER")
    if planner not in PLANNERS:
        raise UsageError(f"{shown('WAREHOUSE_PHYS_PLANNER', planner)}: not a planner; known: "
                         f"{', '.join(PLANNERS)}")  # fmt: skip
    if scheduler not in ENTRY_SCHEDULERS:
        raise UsageError(f"{shown('WAREHOUSE_PHYS_SCHEDULER', scheduler)}: not an entry's "
                         f"scheduler; known: {', '.join(ENTRY_SCHEDULERS)}")  # fmt: skip
    try:
        guidance = entry_guidance() if args.guidance is None else args.guidance
        share = round_share()  # read by the entry in the kit: refused here, in one line
    except ValueError as error:
        raise UsageError(str(error)) from None
    try:  # on a small floor: the fields alone, before the kit runs
        entry_planner(planner, WarehouseGrid(2, 2), guidance=guidance)
    except (TypeError, ValueError) as error:
        raise UsageError(f"--guidance: {error}") from None
    return planner, scheduler, guidance, share


def main(argv: list[str] | None = None) -> int:
    """Run the command line; returns the exit status (see the module)."""
    try:
        args = build_parser().parse_args(argv)
        if args.command == "install":
            return _install(args)
        if args.command == "build":
            built = build_kit(args.kit, jobs=args.jobs, quiet=False)
            print(f"the start kit is built: {built.lifelong}")
            return 0
        return _run(args)
    except (UsageError, NotAKitError, RunFolderError) as error:
        print(f"{PROG}: error: {error}", file=sys.stderr)
        return 2
    except (KitBuildError, OSError, RunWriteError) as error:
        print(f"{PROG}: error: {str(error).splitlines()[0]}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"{PROG}: stopped (Ctrl-C)", file=sys.stderr)
        return 130


def _install(args: argparse.Namespace) -> int:
    try:
        written = install(args.kit, force=args.force)
    except InstallError as error:
        raise UsageError(str(error)) from None
    for path in written:
        print(f"wrote {path}")
    flags = "--plannerPython true --schedulerPython true --executorPython true"
    print(f"build the kit, then run its ./build/lifelong with {flags} from {args.kit}")
    return 0


def _run(args: argparse.Namespace) -> int:
    try:
        instance = read_instance(args.instance)
    except (ValueError, TypeError, OSError) as error:
        raise UsageError(str(error).splitlines()[0]) from None
    if not args.kit.is_dir() and args.only != "simulate":
        raise UsageError(f"--kit {args.kit}: not a folder (give the start kit's source)")
    planner, scheduler, guidance, share = _entry(args)
    out = args.out
    wanted = [args.only] if args.only else list(RUNS)
    setting = {"instance": str(args.instance), "ticks": args.ticks, "kit": str(args.kit),
               "planner": planner, "scheduler": scheduler, "guidance": guidance,
               "round_share": share}  # fmt: skip
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out {out}: not a folder")
    # The folder is locked for the whole command, as a training run's is, so that two
    # commands never write into one folder at once; made here, it goes again if the
    # command ends with it empty.
    created = make_folders(out, exist_ok=True)
    try:
        handle = lock_folder(out)
        try:
            try:
                kept = prepare_folder(out, wanted, setting, overwrite=args.overwrite)
            except RunFolderRefused as error:
                raise UsageError(str(error)) from None
            return _run_locked(args, instance, wanted, setting, kept)
        finally:
            os.close(handle)  # releases the lock
    except BaseException:
        remove_empty(created)
        raise


def _run_locked(
    args: argparse.Namespace,
    instance: LorrInstance,
    wanted: list[str],
    setting: dict[str, Any],
    kept: list[dict[str, Any]],
) -> int:
    """The runs ``wanted`` of ``_run``, of ``setting``, into ``args.out``, locked and
    prepared; ``kept``: the earlier runs' summary entries that stay beside them."""
    out = args.out
    planner, scheduler, guidance = setting["planner"], setting["scheduler"], setting["guidance"]
    load_before = os.getloadavg()
    results, build = [], None
    if {"ours", "default"} & set(wanted):
        build = build_kit(args.kit, jobs=args.jobs, quiet=False)
    size = 1.0 if instance.agent_size is None else instance.agent_size
    entry = {"WAREHOUSE_PHYS_PLANNER": planner, "WAREHOUSE_PHYS_SCHEDULER": scheduler,
             "WAREHOUSE_PHYS_GUIDANCE": json.dumps(guidance)}  # fmt: skip
    for name in ("ours", "default"):
        if name in wanted:
            print(f"running the kit with {'the entry' if name == 'ours' else 'its default entry'}"
                  f" ({args.ticks:,} ticks)...", file=sys.stderr, flush=True)  # fmt: skip
            results.append(run_kit(build, args.instance, out / f"{name}.json", args.ticks,
                                   entry=name, agent_size=size, settings=entry))  # fmt: skip
    if "simulate" in wanted:
        source = next((out / f"{n}.json" for n in ("ours", "default")
                       if (out / f"{n}.json").is_file()), None)  # fmt: skip
        print("running simulate by the kit's rules...", file=sys.stderr, flush=True)
        results.append(run_simulate(args.instance, out / "simulate", args.ticks,
                                    delays_from=source, planner=planner,
                                    scheduler=FLEET_SCHEDULERS[scheduler],
                                    guidance=guidance))  # fmt: skip
    load = {"before": list(load_before), "after": list(os.getloadavg())}
    runs = kept + [result.to_json() | {"load_average": load, "cpus": os.cpu_count()}
                   | ({} if result.name == "simulate" else {"build": str(build.folder)})
                   for result in results]  # fmt: skip
    summary = {**setting, "robots": instance.team_size,
               "runs": sorted(runs, key=lambda run: RUNS.index(run["name"]))}  # fmt: skip
    atomic_write_text(out / SUMMARY, json.dumps(summary, indent=2) + "\n")
    print(
        f"{instance.name}, {instance.team_size:,} robots, {args.ticks:,} ticks, the entry's "
        f"{planner} and {scheduler} (load average {load_before[0]:.1f} before, "
        f"{os.getloadavg()[0]:.1f} after):"
    )
    print(comparison_table(results))
    for result in results:
        if result.note:
            print(f"{result.name}: {result.note}")
    names = sorted(path.name for path in out.iterdir() if not path.name.startswith("."))
    print(f"wrote {out}/: {', '.join(names)}")
    failed = [r for r in results if r.returncode]
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
