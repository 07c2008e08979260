"""Figures of the physics twin at scale: time and memory a tick against the bodies,
``benchmarks/physics_scale.py``'s results."""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path

from matplotlib.figure import Figure

from warehouse_phys.viz.figures import new_figure

__all__ = ["physics_scaling_figure"]


def physics_scaling_figure(scaling: Mapping[str, object] | str | os.PathLike[str]) -> Figure:
    """CPU time a tick against the number of bodies, each candidate's (one thread, two,
    with and without the safety measures; two threads' critical path dashed), with the
    tick's simulated time beside it (real time), and the peak memory against the bodies:
    ``benchmarks/physics_scale.py``'s ``"scaling"`` mapping, or the path of the JSON file
    it wrote.

    Raises:
        ValueError: if the file holds no scaling rows.
    """
    if not isinstance(scaling, Mapping):
        scaling = json.loads(Path(scaling).read_text(encoding="utf-8")).get("scaling")
        if not scaling:
            raise ValueError("the file holds no scaling rows (benchmarks/physics_scale.py)")
    rows = list(scaling["rows"])
    figure = new_figure((10.0, 4.0))
    timing, memory = figure.subplots(1, 2)
    for name in dict.fromkeys(row["candidate"] for row in rows):
        mine = sorted((row for row in rows if row["candidate"] == name), key=lambda r: r["robots"])
        robots = [row["robots"] for row in mine]
        (line,) = timing.plot(robots, [row["ms_per_tick"] for row in mine], marker="o",
                              label=f"{name}, CPU")  # fmt: skip
        if mine[0]["threads"] > 1:
            timing.plot(
                robots,
                [row["critical_ms_per_tick"] for row in mine],
                "--",
                color=line.get_color(),
                marker=".",
                label=f"{name}, critical path",
            )
    sizes = sorted({row["robots"] for row in rows})
    tick = sizes[0] and rows[0]["ms_per_tick"] * rows[0]["real_time_cpu"]  # ms simulated
    timing.axhline(tick, color="k", linewidth=0.8, linestyle=":")
    timing.text(sizes[0], tick, " real time", va="bottom", fontsize=8)
    timing.set_xscale("log")
    timing.set_yscale("log")
    timing.set_xlabel("bodies")
    timing.set_ylabel("ms a tick")
    timing.set_title(f"{scaling['map']}, {scaling['ticks']} ticks x {scaling['rounds']} rounds")
    timing.grid(alpha=0.3, which="both")
    timing.legend(fontsize=7)
    peak = {row["robots"]: row["peak_mib"] for row in rows}
    memory.plot(sizes, [peak[n] for n in sizes], "k", marker="o")
    memory.set_xlabel("bodies")
    memory.set_ylabel("peak memory beyond the process [MiB]")
    memory.set_title("the world of two threads, safety measured")
    memory.grid(alpha=0.3)
    return figure
