"""The package's entry in the League of Robot Runners' own simulator (the start kit 3.1.0).

    python benchmarks/startkit.py --kit ../shared/lorr/start-kit-3.1.0 --json results.json

Three parts, each a ``python -m warehouse_phys.startkit run`` or its parts
(:mod:`warehouse_phys.lorr.startkit.runs`), every run on this machine in this command:

1. **Targets** (``--targets``): ``random-example_400`` and ``maze-example_40`` (from
   ``../shared/lorr``) and a 2,500-robot 2026 instance made here
   (:func:`~warehouse_phys.lorr.generator.make_instance` on ``warehouse-large-140-500``,
   20,000 tasks of 2 errands, seed 0, the 2026 examples' ticks and delays), ``--ticks``
   ticks each: the kit with the entry, the kit's default entry, and ``simulate`` by the
   kit's rules with the first run's delays. Tasks finished, the kit's refused motions and
   errors, the planner's late checks and the executor's timeout ticks, wall and CPU time.
2. **Executors** (``--executors``): ``random-example_400`` at pDelay 0.0005, 0.005 and 0.02
   (its ``delayConfig`` otherwise), the entry's planner and scheduler with its executor
   and with the kit's default executor (``--executorPython false``), on the same delays
   (the kit draws them from the instance's seed for both), and ``simulate
   --delays-from`` the first.
3. **Time at 10,000 robots** (``--ten-thousand``): a 10,000-robot instance made as above
   (40,000 tasks), ``--ten-thousand-ticks`` ticks of the kit with the entry, as it is
   (guided PIBT, the assignment scheduler) and with its fastest parts (PIBT, the makespan
   pairing: ``WAREHOUSE_PHYS_PLANNER=pibt WAREHOUSE_PHYS_SCHEDULER=makespan``): each
   call's wall time against the kit's limits (``planCommTimeLimit`` 1,000 ms for the
   scheduler and the planner together, 100 ms for each of the executor's).

Generated instances and the runs' files go to ``--work`` (a temporary folder by default),
never into the repository. The machine's load average is recorded before and after each
run: figures measured beside other work say so.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from warehouse_phys.lorr.generator import make_instance
from warehouse_phys.lorr.instances import read_instance, write_instance
from warehouse_phys.lorr.startkit.build import KitBuild, build_kit
from warehouse_phys.lorr.startkit.runs import RunResult, comparison_table, run_kit, run_simulate
from warehouse_phys.world.layouts import read_movingai

SHARED = Path(__file__).resolve().parents[2] / "shared"
EXAMPLES = {
    "random-example_400": SHARED / "lorr" / "2026-examples-random" / "random-example_400.json",
    "maze-example_40": SHARED / "lorr" / "2026-examples-maze" / "maze-example_40.json",
}
WAREHOUSE_MAP = SHARED / "maps" / "warehouse-large-140-500.map"
P_DELAYS = (0.0005, 0.005, 0.02)


def generated(work: Path, robots: int, tasks: int) -> Path:
    """A 2026 instance of ``robots`` robots on warehouse_large, written under ``work``."""
    name = f"warehouse-large-{robots}"
    path = work / "instances" / f"{name}.json"
    if not path.is_file():
        instance = make_instance(read_movingai(WAREHOUSE_MAP), robots, tasks, seed=0, name=name)
        write_instance(instance, path, map_name="warehouse-large-140-500")
    return path


def with_p_delay(source: Path, p_delay: float, work: Path) -> Path:
    """A copy of the instance ``source`` with ``pDelay`` replaced, its map, agents and tasks
    linked from the original's folder."""
    folder = work / f"pdelay-{p_delay:g}"
    folder.mkdir(parents=True, exist_ok=True)
    data = json.loads(source.read_text())
    data["delayConfig"]["pDelay"] = p_delay
    for key in ("mapFile", "agentFile", "taskFile"):
        target = folder / data[key]
        target.parent.mkdir(parents=True, exist_ok=True)
        if not target.exists():
            target.symlink_to((source.parent / data[key]).resolve())
    path = folder / source.name
    path.write_text(json.dumps(data, indent=4) + "\n")
    return path


def three_runs(build: KitBuild, instance: Path, out: Path, ticks: int) -> list[RunResult]:
    """The kit with the entry, its default entry, and simulate on the first's delays."""
    size = read_instance(instance).agent_size or 1.0
    results = []
    for name in ("ours", "default"):
        results.append(_loaded(run_kit, build, instance, out / f"{name}.json", ticks, entry=name,
                               agent_size=size))  # fmt: skip
    results.append(_loaded(run_simulate, instance, out / "simulate", ticks,
                           delays_from=out / "ours.json"))  # fmt: skip
    return results


def _loaded(run: Callable[..., RunResult], *args: Any, **kwargs: Any) -> RunResult:
    """``run`` with the load average before and after it in its note."""
    before = os.getloadavg()[0]
    result = run(*args, **kwargs)
    result.note = f"{result.note}; load {before:.1f} -> {os.getloadavg()[0]:.1f}".lstrip("; ")
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--kit", type=Path, default=SHARED / "lorr" / "start-kit-3.1.0")
    parser.add_argument("--ticks", type=int, default=600)
    parser.add_argument("--ten-thousand-ticks", type=int, default=300)
    parser.add_argument("--work", type=Path, default=None)
    parser.add_argument("--json", type=Path, default=None)
    parser.add_argument("--targets", action="store_true")
    parser.add_argument("--executors", action="store_true")
    parser.add_argument("--ten-thousand", action="store_true")
    args = parser.parse_args(argv)
    parts = [p for p in ("targets", "executors", "ten_thousand") if getattr(args, p)]
    parts = parts or ["targets", "executors", "ten_thousand"]
    work = args.work or Path(tempfile.mkdtemp(prefix="warehouse_phys-startkit-"))
    build = build_kit(args.kit, quiet=False)
    report: dict = {"kit": str(args.kit), "ticks": args.ticks, "cpus": os.cpu_count(),
                    "work": str(work)}  # fmt: skip
    if "targets" in parts:
        instances = {**EXAMPLES, "warehouse-large-2500": generated(work, 2500, 20_000)}
        report["targets"] = {}
        for name, path in instances.items():
            results = three_runs(build, path, work / "targets" / name, args.ticks)
            report["targets"][name] = [r.to_json() for r in results]
            print(f"{name}, {args.ticks} ticks:\n{comparison_table(results)}", flush=True)
    if "executors" in parts:
        report["executors"] = {}
        for p_delay in P_DELAYS:
            instance = with_p_delay(EXAMPLES["random-example_400"], p_delay, work)
            out = work / "executors" / f"{p_delay:g}"
            ours = _loaded(run_kit, build, instance, out / "ours.json", args.ticks)
            kits = _loaded(run_kit, build, instance, out / "kit-executor.json", args.ticks,
                           extra=("--executorPython", "false"))  # fmt: skip
            kits.name = "ours+kit executor"
            sim = _loaded(run_simulate, instance, out / "simulate", args.ticks,
                          delays_from=out / "ours.json")  # fmt: skip
            report["executors"][f"{p_delay:g}"] = [r.to_json() for r in (ours, kits, sim)]
            print(f"pDelay {p_delay:g}:\n{comparison_table([ours, kits, sim])}", flush=True)
    if "ten_thousand" in parts:
        path = generated(work, 10_000, 40_000)
        report["ten_thousand"] = {}
        fastest = {"WAREHOUSE_PHYS_PLANNER": "pibt", "WAREHOUSE_PHYS_SCHEDULER": "makespan"}
        for label, settings in (("entry", {}), ("fastest", fastest)):
            result = _loaded(run_kit, build, path, work / "ten-thousand" / f"{label}.json",
                             args.ten_thousand_ticks, settings=settings)  # fmt: skip
            report["ten_thousand"][label] = result.to_json()
            print(f"10,000 robots, {label}, {args.ten_thousand_ticks} ticks:\n"
                  f"{comparison_table([result])}")  # fmt: skip
            for call, timing in (result.timings or {}).items():
                cpu = timing.get("cpu_median_ms")
                cpu_text = "" if cpu is None else f" (CPU {cpu:.0f} ms)"
                print(f"  {call}: {timing['count']} calls, median {timing['median_ms']:.0f} ms"
                      f"{cpu_text}, slowest {timing['max_ms']:.0f} ms, "
                      f"{timing['over_limit']:.0%} over the limit")  # fmt: skip
    if args.json is not None:
        args.json.write_text(json.dumps(report, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
