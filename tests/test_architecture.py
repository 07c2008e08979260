"""The package's floors: each imports only the floors below it, no module imports itself
round a circle, modules stay short (or ARCHITECTURE.md says why not), the old module
paths still import, and the pure floors keep their functions short."""

from __future__ import annotations

import ast
import importlib
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import ROOT
from warehouse_phys._moved import MOVED, OLD_PACKAGES

PACKAGE = ROOT / "warehouse_phys"
#: Each floor's height: a module may import its own floor's modules and lower floors'.
#: physics and drawing stand side by side, neither importing the other.
FLOORS = {"files": 0, "world": 1, "planners": 2, "execution": 3, "lorr": 4, "physics": 5,
          "drawing": 5, "envs": 6, "rl": 7, "viz": 8, "apps": 9}  # fmt: skip
#: The floors of pure rules and bodies, whose functions stay short.
PURE_FLOORS = ("world", "planners", "execution", "lorr", "physics")
#: Longest function of the pure floors, its docstring left out [lines].
MAX_FUNCTION_LINES = 60
#: Longest module without a reason in ARCHITECTURE.md [lines].
MAX_MODULE_LINES = 500


def floor_modules() -> list:
    """Every module of every floor, those of the floors' own subpackages included."""
    return sorted(path for floor in FLOORS for path in (PACKAGE / floor).rglob("*.py"))


def floor_of(path: Path) -> str:
    return path.relative_to(PACKAGE).parts[0]


def runtime_import_nodes(tree: ast.Module) -> list[ast.Import | ast.ImportFrom]:
    """Every import statement of ``tree``, lazy ones included, but not those made for
    type checking only."""
    # Type checking's imports, and a module __getattr__'s: the one way a name that moved
    # to a floor above is still found where it was (on demand, never at import).
    exempt_blocks = [
        block
        for block in ast.walk(tree)
        if (isinstance(block, ast.If) and "TYPE_CHECKING" in ast.unparse(block.test))
        or (isinstance(block, ast.FunctionDef) and block.name == "__getattr__")
    ]
    checking_only = {
        id(node) for block in exempt_blocks for statement in block.body
        for node in ast.walk(statement)
    }  # fmt: skip
    return [
        node
        for node in ast.walk(tree)
        if isinstance(node, (ast.Import, ast.ImportFrom)) and id(node) not in checking_only
    ]


def runtime_imports(tree: ast.Module) -> list[tuple[int, str]]:
    """``(line, module)`` of every import of the package, lazy ones included, but not
    those made for type checking only."""
    found = []
    for node in runtime_import_nodes(tree):
        if isinstance(node, ast.ImportFrom) and node.module:
            names = [node.module] if node.module != "warehouse_phys" else [
                f"warehouse_phys.{alias.name}" for alias in node.names
            ]  # fmt: skip
            found += [(node.lineno, name) for name in names]
        elif isinstance(node, ast.Import):
            found += [(node.lineno, alias.name) for alias in node.names]
    return [(line, name) for line, name in found if name.startswith("warehouse_phys.")]


@pytest.mark.parametrize(
    "path", floor_modules(), ids=lambda path: str(path.relative_to(PACKAGE).with_suffix(""))
)
def test_every_module_imports_only_its_floor_and_those_below(path):
    floor = floor_of(path)
    for line, name in runtime_imports(ast.parse(path.read_text())):
        parts = name.split(".")
        old = parts[1] in MOVED or parts[1] in OLD_PACKAGES
        assert not old, f"{path.name}:{line} imports the old path {name}"
        if parts[1] in FLOORS and parts[1] != floor:
            assert FLOORS[parts[1]] < FLOORS[floor], (
                f"{floor}/{path.name}:{line} imports {name}, on a floor not below {floor}"
            )


def test_the_floor_check_finds_an_upward_import():
    tree = ast.parse("from warehouse_phys.envs.fleet import parallel_env\n")
    assert runtime_imports(tree) == [(1, "warehouse_phys.envs.fleet")]
    checking = "if TYPE_CHECKING:\n    import warehouse_phys.envs\n"
    assert runtime_imports(ast.parse(checking)) == []
    lazy = "def f():\n    from warehouse_phys.viz import plots\n"
    assert runtime_imports(ast.parse(lazy)) == [(2, "warehouse_phys.viz")]


def package_modules() -> dict[str, Path]:
    """Every module of the package by dotted name (a package by its own name)."""
    found = {}
    for path in PACKAGE.rglob("*.py"):
        parts = path.relative_to(ROOT).with_suffix("").parts
        found[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return found


def import_graph(modules: dict[str, Path]) -> dict[str, set[str]]:
    """Module -> the package modules it imports at run time (lazy imports included): the
    deepest module each import names (``from a.b import c`` is ``a.b.c`` where that is a
    module, else ``a.b``)."""
    graph = {}
    for name, path in modules.items():
        targets = set()
        for node in runtime_import_nodes(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                targets |= {alias.name for alias in node.names}
            elif node.module:
                targets |= {
                    f"{node.module}.{alias.name}"
                    if f"{node.module}.{alias.name}" in modules else node.module
                    for alias in node.names
                }  # fmt: skip
        graph[name] = {target for target in targets if target in modules and target != name}
    return graph


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The import graph's strongly connected components of more than one module (Tarjan's
    algorithm, iterative): each is a circle of modules importing each other."""
    index, low, on_stack, stack, found = {}, {}, set(), [], []
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is None:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == node:
                            break
                    if len(component) > 1:
                        found.append(sorted(component))
            elif child not in index:
                index[child] = low[child] = len(index)
                stack.append(child)
                on_stack.add(child)
                work.append((child, iter(sorted(graph[child]))))
            elif child in on_stack:
                low[node] = min(low[node], index[child])
    return found


def test_no_module_of_the_package_imports_itself_round_a_circle():
    found = circles(import_graph(package_modules()))
    assert found == [], f"modules importing each other round a circle: {found}"


def test_the_circle_check_finds_a_circle_through_a_lazy_import():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": set()}
    assert circles(graph) == [["a", "b", "c"]]
    assert circles({"a": {"b"}, "b": set()}) == []


def long_module_reasons() -> dict[str, str]:
    """ARCHITECTURE.md's list of modules over :data:`MAX_MODULE_LINES` lines, each with
    its one-line reason: ``- `floor/module.py`: reason``."""
    text = (ROOT / "ARCHITECTURE.md").read_text()
    _, _, section = text.partition("## Modules over 500 lines")
    section = section.split("\n## ", 1)[0]
    reasons = {}
    for line in section.splitlines():
        if line.startswith("- `"):
            path, _, reason = line[3:].partition("`: ")
            reasons[path] = reason.strip()
    return reasons


def test_every_module_over_500_lines_has_its_reason_in_the_architecture():
    reasons = long_module_reasons()
    lengths = {
        str(path.relative_to(PACKAGE)): len(path.read_text().splitlines())
        for path in PACKAGE.rglob("*.py")
    }
    long = {path: lines for path, lines in lengths.items() if lines > MAX_MODULE_LINES}
    unexplained = {path: lines for path, lines in long.items() if not reasons.get(path)}
    assert unexplained == {}, f"modules over {MAX_MODULE_LINES} lines with no reason given"
    stale = sorted(set(reasons) - set(long))
    assert stale == [], f"ARCHITECTURE.md gives reasons for modules no longer long: {stale}"


@pytest.mark.parametrize("floor", PURE_FLOORS)
def test_functions_of_the_pure_floors_are_short(floor):
    for path in sorted((PACKAGE / floor).rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            if not isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            first = node.body[0]
            has_doc = isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant)
            start = first.end_lineno + 1 if has_doc and len(node.body) > 1 else first.lineno
            lines = node.end_lineno - start + 1
            assert lines <= MAX_FUNCTION_LINES, f"{path.name}: {node.name} has {lines} lines"


@pytest.mark.parametrize("old", sorted(MOVED))
def test_every_old_module_path_is_the_module_at_its_new_one(old):
    module = importlib.import_module(f"warehouse_phys.{old}")
    assert module is importlib.import_module(f"warehouse_phys.{MOVED[old]}")
    assert module.__spec__.name == f"warehouse_phys.{MOVED[old]}"  # its own spec kept


def test_the_names_the_readme_and_notebooks_import_still_import_from_the_old_paths():
    code = (
        "from warehouse_phys.fleet import parallel_env, env\n"
        "from warehouse_phys.planning import pibt_policy\n"
        "from warehouse_phys.qlearning import QLearningConfig, evaluate, train, table_metadata\n"
        "from warehouse_phys.qlearning import load_q_table, save_q_table, greedy_action\n"
        "from warehouse_phys.recording import record_episode, sample_snap_errors\n"
        "from warehouse_phys.fleet_learning import greedy_fleet_policy, record_fleet_episode\n"
        "from warehouse_phys.fleet_evaluation import compare_policies, evaluate_throughput\n"
        "from warehouse_phys.physics import PhysicsConfig, PhysicsWorld, speed_profile\n"
        "from warehouse_phys.envs import WarehouseGridEnv, WarehousePhysicsEnv\n"
        "from warehouse_phys.layouts import suggested_time_limit\n"
        "from warehouse_phys.simulate import simulate\n"
        "from warehouse_phys import Action, batched_physics, fleet, plots, sweep, train\n"
        "import warehouse_phys.train as app\n"
        "assert app.main is train.main and fleet.parallel_env is parallel_env\n"
    )
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert result.returncode == 0, result.stderr


@pytest.mark.parametrize("app", ["train", "play", "simulate", "sweep"])
def test_python_dash_m_runs_every_app_by_its_old_name(app):
    result = subprocess.run(
        [sys.executable, "-m", f"warehouse_phys.{app}", "--help"], capture_output=True, text=True
    )
    assert result.returncode == 0, result.stderr
    assert result.stdout.startswith(f"usage: python -m warehouse_phys.{app}")


#: Most modules one package holds side by side (its __init__ and __main__ not counted).
MAX_MODULES_SIDE_BY_SIDE = 12


def test_no_package_holds_more_than_a_dozen_modules_side_by_side():
    crowded = {}
    for init in PACKAGE.rglob("__init__.py"):
        modules = [p for p in init.parent.glob("*.py") if p.stem not in ("__init__", "__main__")]
        if len(modules) > MAX_MODULES_SIDE_BY_SIDE:
            crowded[str(init.parent.relative_to(ROOT))] = len(modules)
    assert crowded == {}, f"packages that became halls again: {crowded}"


#: Heavy modules the commands import where they use them (ARCHITECTURE.md): the fleets'
#: bodies, schedulers and planners' kernels (numba, SciPy's), the figures, Ray. Together
#: 0.7 s of CPU at every start of a command that needs none of them.
HEAVY_MODULES = ("numba", "scipy.ndimage", "scipy.sparse", "scipy.spatial", "matplotlib", "ray")


@pytest.mark.parametrize(
    "module",
    ["warehouse_phys", "warehouse_phys.train", "warehouse_phys.play", "warehouse_phys.sweep",
     "warehouse_phys.evaluate", "warehouse_phys.envs.fleet"],
)  # fmt: skip
def test_the_commands_leave_the_heavy_modules_to_where_they_are_used(run_python, module):
    # A fresh `import warehouse_phys` (every command and subprocess pays it) takes about
    # 0.3 s. `python -m warehouse_phys.train` (the README's first command) trains one
    # robot: it imports the fleets' module for its fleet options, not the bodies, the
    # schedulers' matching or the planners' kernels, which a fleet loads at its first reset.
    loaded = run_python(
        f"import sys, {module}\nprint(sorted(m for m in {HEAVY_MODULES!r} if m in sys.modules))"
    )
    assert loaded.strip() == "[]"


def test_a_fleet_of_bodies_loads_them_at_its_first_reset(run_python):
    loaded = run_python(
        "import sys\n"
        "from warehouse_phys.envs.fleet import parallel_env\n"
        "env = parallel_env(num_robots=3, physics=True)\n"
        "env.reset(seed=0)\n"
        "print('warehouse_phys.physics.batched' in sys.modules, 'numba' in sys.modules)"
    )
    assert loaded.split() == ["True", "True"]
