"""The package's old module paths, which still import: ``warehouse_phys.grid`` is
:mod:`warehouse_phys.rules.grid`, the same module object, and so on for every module
that moved into a subpackage (see ARCHITECTURE.md).

A finder on :data:`sys.meta_path` answers an import of an old path with the module at
its new one, so code and notebooks written against the flat layout keep working,
monkeypatching included. ``python -m warehouse_phys.train`` (and play, simulate, sweep)
runs through the small modules of those names instead, which runpy needs as files.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
from types import ModuleType

#: Old module (under ``warehouse_phys.``) -> where it lives now.
MOVED: dict[str, str] = {
    "atomic": "files.atomic",
    "npzfile": "files.npzfile",
    "runfolder": "files.runfolder",
    "grid": "rules.grid",
    "batched": "rules.batched",
    "layouts": "rules.layouts",
    "traffic": "rules.traffic",
    "distances": "rules.distances",
    "planning": "rules.planning",
    "batched_physics": "physics.batched",
    "render": "drawing.render",
    "animation": "drawing.animation",
    "vector": "envs.vector",
    "fleet": "envs.fleet",
    "qlearning": "rl.qlearning",
    "qtable_file": "rl.qtable_file",
    "fleet_learning": "rl.fleet_learning",
    "fleet_evaluation": "rl.fleet_evaluation",
    "sb3": "rl.sb3",
    "plots": "viz.plots",
    "recording": "viz.recording",
    "cli": "apps.cli",
    "runs": "apps.runs",
}


class _MovedModuleFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds ``warehouse_phys.<old>`` and loads it as the module at its new path."""

    def find_spec(
        self, fullname: str, path: object = None, target: object = None
    ) -> importlib.machinery.ModuleSpec | None:
        package, _, name = fullname.partition(".")
        if package != "warehouse_phys" or name not in MOVED:
            return None
        return importlib.machinery.ModuleSpec(fullname, self)

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        module = importlib.import_module(f"warehouse_phys.{MOVED[spec.name.partition('.')[2]]}")
        self._spec = module.__spec__  # the import system sets the old name's spec next
        return module

    def exec_module(self, module: ModuleType) -> None:
        module.__spec__ = self._spec  # the module keeps its own spec (its real name)


def install() -> None:
    """Let the old module paths import (once per process)."""
    if not any(isinstance(finder, _MovedModuleFinder) for finder in sys.meta_path):
        sys.meta_path.append(_MovedModuleFinder())
