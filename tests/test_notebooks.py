"""The notebooks as files: what they promise a reader, checked without running them.

Running them is nbmake's job: ``python -m pytest`` executes every notebook in
``notebooks/`` in a fresh kernel (see ``addopts`` in pyproject.toml), so a
notebook that raises fails the run. These tests check what a run cannot: that
each notebook says what it shows, imports nothing but the package (and
Gymnasium, to make environments), defines no helpers of its own, was stored
run top to bottom, and stays small.
"""

import ast
import json

import pytest

from tests.conftest import ROOT

NOTEBOOKS = ROOT / "notebooks"
EXPECTED = ["fleet.ipynb", "smooth_vs_discrete.ipynb", "training.ipynb"]
MAX_BYTES = 2 * 1024 * 1024
#: What a notebook may import: the package, and Gymnasium to make its environments.
ALLOWED_IMPORTS = {"warehouse_phys", "gymnasium"}


def load(name):
    return json.loads((NOTEBOOKS / name).read_text(encoding="utf-8"))


def code_cells(notebook):
    return [cell for cell in notebook["cells"] if cell["cell_type"] == "code"]


def python_source(cell):
    """The cell's source without IPython magics (``%matplotlib inline``)."""
    lines = "".join(cell["source"]).splitlines()
    return "\n".join(line for line in lines if not line.lstrip().startswith(("%", "!")))


def test_the_notebooks_are_there():
    assert sorted(p.name for p in NOTEBOOKS.glob("*.ipynb")) == EXPECTED


@pytest.mark.parametrize("name", EXPECTED)
def test_opens_with_a_paragraph_saying_what_it_shows(name):
    first = load(name)["cells"][0]
    assert first["cell_type"] == "markdown"
    text = "".join(first["source"])
    title, *body = text.splitlines()
    assert title.startswith("# ")
    paragraph = " ".join(line for line in body if line.strip())
    assert len(paragraph) > 200, paragraph
    assert paragraph.count(".") >= 2  # sentences, not a caption


@pytest.mark.parametrize("name", EXPECTED)
def test_imports_only_the_package_and_defines_no_helpers(name):
    for cell in code_cells(load(name)):
        tree = ast.parse(python_source(cell))
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                roots = {alias.name.split(".")[0] for alias in node.names}
            elif isinstance(node, ast.ImportFrom):
                roots = {(node.module or "").split(".")[0]}
            else:
                roots = set()
            assert roots <= ALLOWED_IMPORTS, ast.unparse(node)
            if isinstance(node, ast.ClassDef | ast.AsyncFunctionDef):
                pytest.fail(f"{name} defines {node.name}: helpers belong in the package")
            if isinstance(node, ast.FunctionDef):
                # One-line wrappers that name a policy are fine; logic is not.
                assert len(node.body) == 1, f"{name} defines {node.name} with logic of its own"
                assert isinstance(node.body[0], ast.Return), ast.unparse(node)


@pytest.mark.parametrize("name", EXPECTED)
def test_stored_run_top_to_bottom_without_errors(name):
    cells = code_cells(load(name))
    assert [cell["execution_count"] for cell in cells] == list(range(1, len(cells) + 1))
    for cell in cells:
        assert all(output["output_type"] != "error" for output in cell["outputs"])
        assert not any(output.get("name") == "stderr" for output in cell["outputs"]), (
            "warnings or errors printed"
        )
    kinds = {
        kind for cell in cells for output in cell["outputs"] for kind in output.get("data", {})
    }
    assert "image/png" in kinds  # the figures were stored, not just their text repr


def test_smooth_vs_discrete_stores_both_animations_inline():
    cells = code_cells(load("smooth_vs_discrete.ipynb"))
    gifs = [
        output["data"]["text/html"]
        for cell in cells
        for output in cell["outputs"]
        if "data:image/gif;base64," in "".join(output.get("data", {}).get("text/html", ""))
    ]
    assert len(gifs) == 2


@pytest.mark.parametrize("name", EXPECTED)
def test_stays_small(name):
    assert (NOTEBOOKS / name).stat().st_size < MAX_BYTES
