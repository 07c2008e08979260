"""The folder of ``python -m warehouse_phys.startkit run``: what it holds, and when a run may
write into one that holds an earlier run.

A run of the command writes, for each of its runs
(:data:`~warehouse_phys.lorr.startkit.runs.RUNS`), the files of :func:`run_files` (a kit
run's output, log and call timings and its hidden working folder; ``simulate``'s folder
and log), and one ``summary.json`` over them, which records the *setting* they share (the
instance, ticks, kit, planner, scheduler and the planner's fields). The policy, which
:func:`prepare_folder` applies before anything runs:

- A missing or empty folder is used as it is.
- A folder holding anything that no run of the command writes is refused (unless hidden:
  a file manager's ``.DS_Store`` is left alone).
- A run of all three into a folder holding an earlier run is refused, unless
  ``overwrite``: the earlier run's files are then removed first.
- A run of one (``--only``) adds its files to an earlier run of the same setting (so that
  ``--only simulate`` replays the delays of an ``--only ours`` before it), and the summary
  keeps the earlier runs' entries; but it replaces a run that is already there only with
  ``overwrite``, and a folder holding a run of another setting is refused, or, with
  ``overwrite``, emptied of it first.

So a folder never holds the runs of two settings, a file is replaced only when asked, and
a summary lists every run in its folder. The command holds the folder's lock
(:func:`~warehouse_phys.files.runfolder.lock_folder`) from before this check to its end,
so no other command writes into it meanwhile.
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from warehouse_phys.lorr.startkit.runs import RUNS
from warehouse_phys.lorr.startkit.settings import ROUND_SHARE

#: The summary of the runs in a folder.
SUMMARY = "summary.json"
#: The summary's fields that make the runs of one folder comparable: their setting.
SETTING_FIELDS = ("instance", "ticks", "kit", "planner", "scheduler", "guidance", "round_share")
#: What a field an older summary lacks stood for: the entry's round was always bounded so.
EARLIER_DEFAULTS = {"round_share": ROUND_SHARE}


class RunFolderRefused(ValueError):
    """A folder that this run may not write into; the message says why and what to do."""


def run_files(name: str) -> tuple[str, ...]:
    """The names of the files and folders the run ``name`` (one of :data:`RUNS`) writes
    into the command's folder."""
    if name == "simulate":
        return ("simulate", "simulate.log")
    return (f"{name}.json", f"{name}.log", f"{name}.timings", f".{name}-kit")


def prepare_folder(
    out: Path, wanted: Sequence[str], setting: Mapping[str, Any], *, overwrite: bool
) -> list[dict[str, Any]]:
    """Check ``out`` for the runs ``wanted`` of ``setting`` (:data:`SETTING_FIELDS`, as the
    summary records them) and remove what they replace, by the module's policy; returns
    the entries of the earlier summary's runs that stay beside them (none if the folder
    holds no earlier run). Creates nothing.

    Raises:
        RunFolderRefused: for a folder the policy refuses, naming what it holds.
    """
    if not out.exists():
        return []
    if not out.is_dir():
        raise RunFolderRefused(f"--out {out}: not a folder")
    ours = {SUMMARY, *(name for run in RUNS for name in run_files(run))}
    held = sorted(path.name for path in out.iterdir())
    foreign = [name for name in held if name not in ours and not name.startswith(".")]
    if foreign:
        raise RunFolderRefused(f"--out {out} holds {foreign[0]!r}, which this command does not "
                               "write: choose a new or empty folder")  # fmt: skip
    earlier = [name for name in held if name in ours]
    if not earlier:
        return []
    summary = _summary(out / SUMMARY)
    recorded = {} if summary is None else {**EARLIER_DEFAULTS, **summary}
    differs = [field for field in SETTING_FIELDS
               if summary is None or recorded.get(field) != setting.get(field)]  # fmt: skip
    replaced = [name for name in earlier for run in wanted if name in run_files(run)]
    whole = set(wanted) == set(RUNS) or bool(differs)
    if not overwrite:
        if set(wanted) == set(RUNS):
            shown = [name for name in earlier if not name.startswith(".")] or earlier
            what = f"an earlier run ({', '.join(shown)})"
        elif summary is None:
            what = f"an earlier run without its {SUMMARY}"
        elif differs:
            field = differs[0]
            what = (f"a run of another setting ({field} {recorded.get(field)!r}, not "
                    f"{setting.get(field)!r})")  # fmt: skip
        elif replaced:
            what = f"an earlier {_run_of(replaced[0])} run ({replaced[0]})"
        else:
            return [run for run in summary["runs"] if run.get("name") not in wanted]
        raise RunFolderRefused(f"--out {out} holds {what}: choose a new folder, or pass "
                               "--overwrite to replace it")  # fmt: skip
    for name in earlier if whole else replaced:
        path = out / name
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path)
        else:
            path.unlink(missing_ok=True)
    if whole or summary is None:
        return []
    return [run for run in summary["runs"] if run.get("name") not in wanted]


def _summary(path: Path) -> dict[str, Any] | None:
    """The summary at ``path``, or None where there is none or it is not one."""
    try:
        summary = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    runs = summary.get("runs") if isinstance(summary, dict) else None
    if not isinstance(runs, list) or not all(
        isinstance(run, dict) and run.get("name") in RUNS for run in runs
    ):
        return None
    return summary


def _run_of(name: str) -> str:
    """The run (of :data:`RUNS`) whose file ``name`` is."""
    return next(run for run in RUNS if name in run_files(run))
