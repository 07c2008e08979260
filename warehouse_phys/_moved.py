"""The package's old module paths, which still import: ``warehouse_phys.grid`` and
``warehouse_phys.rules.grid`` are :mod:`warehouse_phys.world.grid`, the same module
object, and so on for every module that moved into a subpackage (see ARCHITECTURE.md).

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

#: The ``rules`` floor's modules -> the packages it was split into (the world, the
#: planners, execution in time, the League of Robot Runners).
RULES: dict[str, str] = {
    "grid": "world.grid",
    "cells": "world.cells",
    "batched": "world.batched",
    "layouts": "world.layouts",
    "traffic": "world.traffic",
    "headings": "world.headings",
    "placement": "world.placement",
    "planning": "planners.pibt",
    "guidance": "planners.guidance",
    "lanes": "planners.lanes",
    "operations": "planners.operations",
    "distances": "planners.distances",
    "graph_search": "planners.graph_search",
    "ticks": "execution.ticks",
    "delays": "execution.delays",
    "executor": "execution.executor",
    "async_grid": "execution.async_grid",
    "windows": "execution.windows",
    "execution": "execution.runner",
    "instances": "lorr.instances",
    "errands": "lorr.errands",
    "scheduling": "lorr.scheduling",
    "task_flow": "lorr.task_flow",
    "lorr_output": "lorr.output",
}

#: Old module (under ``warehouse_phys.``) -> where it lives now: the flat layout's modules
#: and the ``rules`` floor's.
MOVED: dict[str, str] = {
    "atomic": "files.atomic",
    "npzfile": "files.npzfile",
    "runfolder": "files.runfolder",
    "grid": "world.grid",
    "batched": "world.batched",
    "layouts": "world.layouts",
    "traffic": "world.traffic",
    "distances": "planners.distances",
    "planning": "planners.pibt",
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
    "apps.simulate_async": "apps.simulate.on_ticks",
    "envs.fleet_actions": "envs.fleet.actions",
    "envs.fleet_observations": "envs.fleet.observations",
    "planners.guidance_learning": "planners.lanes.learned",
    **{f"rules.{name}": home for name, home in RULES.items()},
}

#: Old packages that hold nothing now but their moved modules' old paths.
OLD_PACKAGES = ("rules",)


class _MovedModuleFinder(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Finds ``warehouse_phys.<old>`` and loads it as the module at its new path."""

    def find_spec(
        self, fullname: str, path: object = None, target: object = None
    ) -> importlib.machinery.ModuleSpec | None:
        package, _, name = fullname.partition(".")
        if package != "warehouse_phys" or (name not in MOVED and name not in OLD_PACKAGES):
            return None
        return importlib.machinery.ModuleSpec(fullname, self, is_package=name in OLD_PACKAGES)

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        name = spec.name.partition(".")[2]
        if name in OLD_PACKAGES:  # an empty package: its old modules are found by this finder
            self._spec = None
            return ModuleType(spec.name, f"The old home of {sorted(RULES)} (see _moved).")
        module = importlib.import_module(f"warehouse_phys.{MOVED[name]}")
        self._spec = module.__spec__  # the import system sets the old name's spec next
        return module

    def exec_module(self, module: ModuleType) -> None:
        if self._spec is not None:
            module.__spec__ = self._spec  # the module keeps its own spec (its real name)


def install() -> None:
    """Let the old module paths import (once per process)."""
    if not any(isinstance(finder, _MovedModuleFinder) for finder in sys.meta_path):
        sys.meta_path.append(_MovedModuleFinder())
