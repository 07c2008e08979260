"""The start kit's three Python files that load the entry: ``python/user_planner/pyMAPFPlanner.py``,
``python/user_scheduler/pyTaskScheduler.py`` and ``python/user_executor/pyExecutor.py``.

The kit's ``lifelong`` embeds the Python it was built against and imports these files
from ``python/user_*/`` *of its working folder*. Each file written here makes this
package and its dependencies importable in that interpreter (``site.addsitedir`` of the
installing environment's site-packages, put first on ``sys.path``, so that its ``.pth``
files, an editable install's among them, are read), refuses in one line an interpreter
of another Python version than the one the package was installed for, and defines the
kit's class as a subclass of the adapter (:mod:`~warehouse_phys.lorr.startkit.adapters`).

:func:`install` writes them into a kit checkout (or any folder a ``lifelong`` runs from).
A file there that this module did not write (a participant's own planner) is kept unless
``force`` is given. Each file is written atomically.
"""

from __future__ import annotations

import os
import sys
import sysconfig
from pathlib import Path

from warehouse_phys.files.atomic import atomic_write_text

#: The line that marks a file as written here.
MARK = "# Written by `python -m warehouse_phys.startkit install`"
#: The kit's three files: (folder, module and class, the adapter it subclasses, what it is).
COMPONENTS = (
    ("user_planner", "pyMAPFPlanner", "PlannerAdapter", "planner"),
    ("user_scheduler", "pyTaskScheduler", "SchedulerAdapter", "scheduler"),
    ("user_executor", "pyExecutor", "ExecutorAdapter", "executor"),
)

_TEMPLATE = '''"""warehouse_phys's {what} for the League of Robot Runners start kit.

It loads warehouse_phys from the environment that installed it and runs
warehouse_phys.lorr.startkit.adapters.{adapter} as the kit's {name}.
"""

{mark} (warehouse_phys {version}); it is
# rewritten by the next install. Settings: WAREHOUSE_PHYS_AGENT_SIZE (the instance's
# agentSize, default 1), WAREHOUSE_PHYS_PLANNER (guided-ops-repair),
# WAREHOUSE_PHYS_SCHEDULER (assignment; assignment-capped,
# assignment-backlog, makespan, nearest),
# WAREHOUSE_PHYS_GUIDANCE (a JSON object of the planner's fields, {{}}).
import site
import sys

_PYTHON = {python!r}
_SITE_PACKAGES = {sites!r}
if sys.version_info[:2] != _PYTHON:
    raise ImportError(
        "warehouse_phys was installed for Python {dotted} ({executable}), but this kit "
        f"runs Python {{sys.version_info[0]}}.{{sys.version_info[1]}}: build the kit against "
        "that interpreter (python -m warehouse_phys.startkit run builds one)"
    )
_BEFORE = list(sys.path)
for _folder in _SITE_PACKAGES:
    site.addsitedir(_folder)
sys.path[:] = [p for p in sys.path if p not in _BEFORE] + _BEFORE

from warehouse_phys.lorr.startkit.adapters import {adapter}  # noqa: E402


class {name}({adapter}):
    """The kit's {what}: warehouse_phys's entry."""
'''


class InstallError(ValueError):
    """A kit folder that the files cannot be written into, in one line."""


def component_files() -> dict[str, str]:
    """The three files' relative paths (``python/user_*/py*.py``) and their text, for the
    running interpreter and its environment."""
    from warehouse_phys import __version__

    paths = sysconfig.get_paths()
    sites = list(dict.fromkeys([paths["purelib"], paths["platlib"]]))
    python = tuple(sys.version_info[:2])
    files = {}
    for folder, name, adapter, what in COMPONENTS:
        files[f"python/{folder}/{name}.py"] = _TEMPLATE.format(
            what=what, adapter=adapter, name=name, mark=MARK, version=__version__,
            python=python, sites=sites, dotted=f"{python[0]}.{python[1]}",
            executable=sys.executable,
        )  # fmt: skip
    return files


def install(folder: str | os.PathLike[str], *, force: bool = False) -> list[Path]:
    """Write the three files under ``folder`` (a start-kit checkout, or a folder a
    ``lifelong`` is run from; ``python/user_*/`` made as needed); returns their paths.

    Raises:
        InstallError: one line, if ``folder`` is not a folder, a kit checkout lacks its
            ``python/`` folder, a file there was not written here (without ``force``), or
            a file cannot be written.
    """
    root = Path(folder)
    if not root.is_dir():
        raise InstallError(f"{root}: not a folder (give a start-kit checkout)")
    if (root / "CMakeLists.txt").is_file() and not (root / "python").is_dir():
        raise InstallError(f"{root}: a start kit without a python/ folder (the kit 3.x has one)")
    files = component_files()
    if not force:
        theirs = [path for path in files if (root / path).is_file()
                  and MARK not in (root / path).read_text(errors="replace")]  # fmt: skip
        if theirs:
            raise InstallError(f"{root / theirs[0]}: a component not written by warehouse_phys; "
                               "keep it, or install with --force to replace it")  # fmt: skip
    written = []
    for relative, text in files.items():
        path = root / relative
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            written.append(atomic_write_text(path, text))
        except OSError as error:
            raise InstallError(f"{path}: cannot write it ({error.strerror or error})") from None
    return written
