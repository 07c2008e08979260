"""The documentation site's configuration (Sphinx, MyST Markdown, the furo theme).

Build it as the tests do (warnings are errors, every reference must resolve; ``-j auto``
reads and writes the pages on every core, which the tests leave to their other workers)::

    python -m sphinx -W -n --keep-going -j auto -b html docs docs/_build/html

The API reference (api.md) is generated from the package's docstrings by autosummary,
one page per module, into ``docs/api/`` (generated, not committed), with the module
template _templates/autosummary/module.rst and the machinery of _ext/apiref.py.
"""

from __future__ import annotations

import sys
from pathlib import Path

import warehouse_phys

sys.path.insert(0, str(Path(__file__).resolve().parent / "_ext"))
import apiref  # found on the path set just above

project = "warehouse_phys"
author = "The warehouse_phys maintainers"
copyright = "The warehouse_phys maintainers"
release = version = warehouse_phys.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "apiref",  # after napoleon: it takes napoleon's place (docs/_ext/apiref.py)
]
source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
templates_path = ["_templates"]
# Only .md and .rst files are pages; the pictures, make_readme_images.py and the
# planners_scaling.json beside them are not read as pages (pages may show the pictures).
exclude_patterns = ["_build", "_templates", "_ext", "**/__pycache__"]

html_theme = "furo"
html_title = "warehouse_phys"
# The API pages list their members themselves; leaving every function and constant out
# of the sidebar's tree (hundreds of entries a page) takes a third off the build.
toc_object_entries = False

# Headings get anchors, so that a page can link to another page's section:
# [the fleet's rewards](fleets.md#rewards).
myst_heading_anchors = 3
myst_enable_extensions = ["colon_fence"]

# Every reference must resolve (the tests build with -n as well). The names of other
# projects cannot: their inventories are not downloaded (no network at build time), so
# their namespaces, and only theirs, are let through. A name of the package resolves as it
# would in Python (docs/_ext/apiref.py): imported by the module, re-exported, inherited.
nitpicky = True
EXTERNAL_NAMESPACES = (
    # Third-party packages the package imports.
    "np|numpy|npt|gym|gymnasium|pettingzoo|pymunk|pygame|matplotlib|mpl|PIL|scipy|numba|"
    "tqdm|ray|stable_baselines3|supersuit|torch|"
    # The standard library.
    "argparse|collections|concurrent|contextlib|dataclasses|datetime|enum|io|json|"
    "math|multiprocessing|os|pathlib|signal|subprocess|sys|threading|time|types|typing|"
    "typing_extensions"
)
BUILTINS = (
    "None|True|False|Ellipsis|bool|int|float|complex|str|bytes|bytearray|list|tuple|dict|"
    "set|frozenset|object|type|slice|range|callable|"
    "BaseException|Exception|ArithmeticError|KeyboardInterrupt|OSError|RuntimeError|"
    "TypeError|ValueError|KeyError|IndexError|FileNotFoundError|FileExistsError|"
    "NotImplementedError|TimeoutError|StopIteration|SystemExit|UserWarning|Warning"
)
nitpick_ignore_regex = [
    (r"py:.*", rf"(~?)({EXTERNAL_NAMESPACES})(\..+)?"),
    (r"py:.*", rf"({BUILTINS})"),
]

# The optional extras, which the build must not need; and the package's __main__ modules,
# which run their command when imported (autosummary imports every module it finds).
autodoc_mock_imports = ["ray", "stable_baselines3", "supersuit", "torch", *apiref.main_modules()]
autodoc_member_order = "bysource"
autodoc_preserve_defaults = True  # a default reads as written (DEFAULT_SEED), not its repr
add_module_names = False
autosummary_generate = True
autosummary_imported_members = False

napoleon_google_docstring = True
napoleon_numpy_docstring = False
napoleon_use_rtype = False

autodoc_type_aliases = apiref.type_checking_aliases()
autosummary_context = {"api_modules": apiref.api_modules()}
