"""An evaluation suite's table and figure: ``results.csv`` and ``results.md`` (a row per
run) and ``results.png`` (:func:`~warehouse_phys.viz.throughput_figures.suite_figure`),
each written whole or not at all."""

from __future__ import annotations

import csv
import io
from pathlib import Path
from typing import Any

from warehouse_phys.files.atomic import atomic_write_text

RESULTS_CSV = "results.csv"
RESULTS_MD = "results.md"
RESULTS_PNG = "results.png"
#: The table's columns, in order, and how the Markdown table writes each.
COLUMNS: dict[str, str] = {
    "instance": "{}", "planner": "{}", "seed": "{}", "robots": "{:,}", "steps": "{:,}",
    "finished": "{:,}", "per_step": "{:.2f}", "first_third": "{:.2f}", "middle_third": "{:.2f}",
    "last_third": "{:.2f}", "last_over_middle": "{:.3f}", "best_known_per_step": "{:.2f}",
    "fraction_of_best": "{:.3f}", "refused": "{:,}", "first_step_cpu_s": "{:.1f}",
    "median_step_cpu_s": "{:.3f}", "max_step_cpu_s": "{:.2f}", "median_step_wall_s": "{:.3f}",
    "max_step_wall_s": "{:.2f}", "cpu_per_step_s": "{:.3f}", "peak_mib": "{:,.0f}",
    "resumed": "{}", "checkpoint_error": "{}", "error": "{}",
}  # fmt: skip


def write_results(folder: Path, rows: list[dict[str, Any]], title: str = "") -> list[Path]:
    """The suite's table (CSV and Markdown) and figure in ``folder``; the paths written."""
    folder = Path(folder)
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=list(COLUMNS), extrasaction="ignore")
    writer.writeheader()
    writer.writerows(rows)
    written = [atomic_write_text(folder / RESULTS_CSV, text.getvalue())]
    written.append(atomic_write_text(folder / RESULTS_MD, markdown_table(rows)))
    finished = [row for row in rows if not row.get("error")]
    if finished:
        from warehouse_phys.viz.figures import save_figure
        from warehouse_phys.viz.throughput_figures import suite_figure

        written.append(save_figure(suite_figure(finished, title), folder / RESULTS_PNG))
    return written


def markdown_table(rows: list[dict[str, Any]]) -> str:
    """The rows as a Markdown table (empty cells for what a row lacks)."""
    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    for row in rows:
        cells = []
        for name, form in COLUMNS.items():
            value = row.get(name)
            cells.append("" if value is None or value == "" else form.format(value))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines) + "\n"
