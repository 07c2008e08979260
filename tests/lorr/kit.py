"""The start kit for the tests that run it: where it is, whether it is built for this
interpreter, its ``MAPF`` module, and scripted runs (robots told GO every tick, their
actions fixed in advance) whose refused motions show the kit's own collision verdicts.

The kit's source is data beside the checkout (``../shared/lorr/start-kit-3.1.0``) and is
built outside it (``python -m warehouse_phys.startkit build``, which ``.ci/run`` runs
before the tests); a test that needs either skips, saying which is missing.
"""

from __future__ import annotations

import ctypes
import importlib
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from tests.conftest import ROOT
from warehouse_phys.lorr.startkit.build import KitBuild, cache_folder

KIT = ROOT.parent / "shared" / "lorr" / "start-kit-3.1.0"

#: The kit 3.1.0's standalone MAPF module misses one symbol (defined in ActionModel.cpp,
#: which its target does not compile in); the tests give it from this shim.
SHIM = """
#include <ostream>
#include "common.h"
std::ostream& operator<<(std::ostream& stream, const Action& action)
{
    return stream << "FRCWT"[static_cast<int>(action)];
}
"""

#: Scripted components: the planner gives each robot its script once, the scheduler no
#: task, the executor stages every action and says GO to every robot every tick.
SCRIPTED = {
    "python/user_planner/pyMAPFPlanner.py": """
import json, os
class pyMAPFPlanner:
    def __init__(self): self.env = None; self.sent = False
    def initialize(self, limit): pass
    def plan(self, limit):
        if self.sent: return [[] for _ in range(self.env.num_of_agents)]
        self.sent = True
        return json.load(open(os.environ["SCRIPT"]))
""",
    "python/user_scheduler/pyTaskScheduler.py": """
class pyTaskScheduler:
    def __init__(self): self.env = None
    def initialize(self, limit): pass
    def plan(self, limit): return [-1] * self.env.num_of_agents
""",
    "python/user_executor/pyExecutor.py": """
class pyExecutor:
    def __init__(self): self.env = None
    def initialize(self, limit): pass
    def process_new_plan(self, limit, plan, staged):
        for robot, actions in enumerate(plan.actions):
            for action in actions: staged[robot].append(action)
        return list(self.env.curr_states)
    def next_command(self, limit): return [0] * self.env.num_of_agents
""",
}


def built_kit() -> KitBuild:
    """The kit built for this interpreter, or skip saying what is missing."""
    if not (KIT / "CMakeLists.txt").is_file():
        pytest.skip(f"no start kit at {KIT} (data beside the checkout, not in the repository)")
    build = KitBuild(KIT.resolve(), cache_folder(KIT))
    if not build.lifelong.is_file():
        pytest.skip(
            f"the start kit is not built for this interpreter in {build.folder}: "
            f"python -m warehouse_phys.startkit build --kit {KIT} (.ci/run does)"
        )
    return build


def mapf_module(build: KitBuild, folder: Path):
    """The kit's ``MAPF`` module (its missing symbol given by :data:`SHIM`), or skip."""
    compiler = shutil.which("g++") or shutil.which("c++")
    if compiler is None or build.mapf_module is None:
        pytest.skip("the kit's MAPF module needs its build and a C++ compiler for its shim")
    source = folder / "shim.cpp"
    source.write_text(SHIM)
    library = folder / "libshim.so"
    subprocess.run([compiler, "-shared", "-fPIC", "-std=c++17", f"-I{build.kit / 'inc'}",
                    str(source), "-o", str(library)], check=True)  # fmt: skip
    ctypes.CDLL(str(library), mode=ctypes.RTLD_GLOBAL)
    sys.path.insert(0, str(build.mapf_module.parent))
    try:
        return importlib.import_module("MAPF")
    finally:
        sys.path.pop(0)


def scripted_run(build: KitBuild, instance: Path, scripts: list[list[int]], ticks: int,
                 folder: Path) -> tuple[dict, set[tuple[int, int]]]:  # fmt: skip
    """Run the kit with :data:`SCRIPTED` components and ``scripts`` (each robot's actions
    in the kit's numbers); its output file and every ``(robot, tick)`` whose motion its
    action model refused (its log's ``reason for waiting``)."""
    for name, text in SCRIPTED.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_text(text)
    (folder / "script.json").write_text(json.dumps(scripts))
    out = folder / "out.json"
    done = subprocess.run(
        [str(build.lifelong), "-i", str(instance), "-o", str(out), "-s", str(ticks),
         "--plannerPython", "true", "--schedulerPython", "true", "--executorPython", "true"],
        cwd=folder, capture_output=True, text=True, env={"SCRIPT": str(folder / "script.json"),
                                                         "PATH": "/usr/bin:/bin"},
    )  # fmt: skip
    assert done.returncode == 0, done.stdout[-2000:] + done.stderr[-2000:]
    refused = {
        (int(m[1]), int(m[2]))
        for m in re.finditer(r"Agent (\d+)'s state: loc=\d+,ori=\d+,t=(\d+)", done.stdout)
    }
    return json.loads(out.read_text()), refused


def kit_step(state: dict, action: int, ticks: int, cols: int) -> dict:
    """One robot's state after taking ``action`` for a tick (the kit's ``result_state``):
    ``cell``, ``heading``, ``count``, ``doing`` (its action under way, -1 none)."""
    new = dict(state)
    if state["count"] and state["doing"] >= 0:
        if action == 3:  # only a wait pauses an action under way
            return new
        action = state["doing"]
    if action in (0, 1, 2):
        new["count"] += 1
        if new["count"] >= ticks:
            new["count"], new["doing"] = 0, -1
            if action == 0:
                new["cell"] += (1, cols, -1, -cols)[state["heading"]]
            else:
                new["heading"] = (state["heading"] + (1 if action == 1 else 3)) % 4
        else:
            new["doing"] = action
    return new


def corner(state: dict, ticks: int, cols: int) -> np.ndarray:
    """The kit's real location of a robot's square, float32 ``(x, y)``."""
    row, col = divmod(state["cell"], cols)
    x, y = np.float32(col), np.float32(row)
    if state["doing"] == 0 and state["count"]:
        frac = np.float32(state["count"]) / np.float32(ticks)
        step = ((1, 0), (0, 1), (-1, 0), (0, -1))[state["heading"]]
        x = x + frac if step[0] > 0 else (x - frac if step[0] < 0 else x)
        y = y + frac if step[1] > 0 else (y - frac if step[1] < 0 else y)
    return np.array([[x, y]], dtype=np.float32)
