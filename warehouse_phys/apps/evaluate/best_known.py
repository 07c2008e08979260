"""The League of Robot Runners' Benchmark-Archive: its main-round instances, their
simulation times and best-known solutions.

The archive (``github.com/MAPF-Competition/Benchmark-Archive``, cloned anywhere outside
this repository) holds, for each year, ``<year> Competition/README.md`` with a table of
best-known solutions (``| Instance | Total Errands Finished | ... | Simulation Time |``;
2024 counts tasks), ``Main Round Evaluation Instances/simulation_time.json`` and the
instances' JSON files. :func:`read_best_known` reads the tables; :func:`main_round_instances`
lists a year's main-round instance files with their simulation times. Nothing here
downloads anything.
"""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path

#: The archive's main-round folder of each year.
MAIN_ROUND = "Main Round Evaluation Instances"
#: Steps of an instance the archive gives no simulation time for.
DEFAULT_STEPS = 5000


@dataclass(frozen=True)
class BestKnown:
    """A best-known solution: what it finished (``count`` errands in 2023, tasks in 2024
    and later) over ``steps`` steps."""

    name: str
    count: int
    steps: int

    @property
    def per_step(self) -> float:
        return self.count / self.steps


def read_best_known(archive: Path) -> dict[str, BestKnown]:
    """Every best-known solution the archive's README tables list, by instance name
    (``MR23-I-10``, ``MR24-WAREHOUSE``, ...).

    Raises:
        ValueError: if ``archive`` holds no such table (not the archive).
    """
    found: dict[str, BestKnown] = {}
    for readme in sorted(Path(archive).glob("* Competition/README.md")):
        header: list[str] | None = None
        for line in readme.read_text(encoding="utf-8").splitlines():
            cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
            if cells and cells[0] == "Instance":
                header = cells
                continue
            if header is None or len(cells) != len(header) or set(cells[0]) <= set("- "):
                continue
            row = dict(zip(header, cells, strict=True))
            count = next((v for k, v in row.items() if k.endswith("Finished")), "")
            steps = row.get("Simulation Time", "")
            if count.isdigit() and steps.isdigit():
                found[cells[0]] = BestKnown(cells[0], int(count), int(steps))
    if not found:
        raise ValueError(f"{archive}: no best-known table (is it the Benchmark-Archive?)")
    return found


def best_known_for(name: str, table: dict[str, BestKnown]) -> BestKnown | None:
    """The best known of the instance called ``name`` (its JSON file's stem): the row of
    that name, or the one row whose name ends in ``-name`` (2024's ``MR24-WAREHOUSE`` for
    ``WAREHOUSE``); None if there is none or more than one."""
    if name in table:
        return table[name]
    matches = [known for key, known in table.items() if key.endswith(f"-{name}")]
    return matches[0] if len(matches) == 1 else None


def main_round_instances(archive: Path, year: int) -> list[tuple[Path, int]]:
    """The main-round instance files of ``year`` in the archive, with each one's
    simulation time (``simulation_time.json``; :data:`DEFAULT_STEPS` where it has none),
    sorted by name. Files whose task or agent files the archive lacks are left out.

    Raises:
        ValueError: if the archive has no main round for ``year``.
    """
    folder = Path(archive) / f"{year} Competition" / MAIN_ROUND
    if not folder.is_dir():
        raise ValueError(f"{archive}: no {year} main round ({folder} is absent)")
    times_file = folder / "simulation_time.json"
    times = json.loads(times_file.read_text(encoding="utf-8")) if times_file.is_file() else {}
    found = []
    for path in sorted(folder.glob("*/*.json"), key=lambda p: p.name):
        try:
            spec = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError):
            continue
        if not all((path.parent / spec.get(key, "")).is_file()
                   for key in ("mapFile", "agentFile", "taskFile")):  # fmt: skip
            continue
        key = re.sub(r"^MR\d\d-", "", path.stem)
        found.append((path, int(times.get(key, times.get(path.stem, DEFAULT_STEPS)))))
    names = [path.stem for path, _ in found]
    # 2023 keeps an older copy of some instances under their short names (I-06.json).
    return [(p, s) for p, s in found if not (p.stem.startswith("I-") and f"MR23-{p.stem}" in names)]
