"""The documentation site (docs/): it builds with no warning and every reference resolved,
a broken one fails it, and every code block of its pages runs as a reader would run it.

The README follows the pages' convention, and its blocks run the same way: it is the
site's front door, at most :data:`README_LINES` lines, and every link of it resolves.

The convention the pages follow (docs/index.md, "How the docs are written"): a block
fenced as ``python`` runs as a script, a ``console`` block's ``$ `` lines run as commands,
each block in a fresh empty folder; ``text`` and plain fences are not run. The ``python``
examples of the package's docstrings, which the API pages show, run too.
"""

import ast
import functools
import inspect
import os
import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import NamedTuple

import pytest

ROOT = Path(__file__).resolve().parent.parent
DOCS = ROOT / "docs"
PACKAGE = ROOT / "warehouse_phys"
README = ROOT / "README.md"
#: The README's length at most [lines]: what it is, the two commands, five capabilities
#: with an example each, and links; everything else is a page of the site.
README_LINES = 250

#: What a copy of docs/ leaves out: a local build, the generated API pages, caches.
NOT_COPIED = ("_build", "api", "__pycache__")
#: Longest a code block of the docs may run [s]: generous, but a hung example fails.
BLOCK_TIMEOUT = 300
#: Longest the build may run here [s]: it takes about 90 s of CPU; a busy machine slows it.
BUILD_TIMEOUT = 600
#: Other names for Python or shell code: refused, so that no example is left out of the
#: tests by its fence (write ``python``, or ``console`` with ``$ `` before each command).
REFUSED_LANGUAGES = frozenset(
    {"py", "python3", "pycon", "ipython", "bash", "sh", "shell", "zsh", "shell-session"}
)
#: A fence (backticks or tildes, three or more) with its info string and its body; the
#: closing fence is the opening one's, so a directive's fence may hold fences of its own.
FENCE = re.compile(
    r"^(?P<indent>[ ]*)(?P<fence>`{3,}|~{3,})(?P<info>[^\n`]*)\n"
    r"(?P<body>.*?)^(?P=indent)(?P=fence)[ \t]*$",
    re.MULTILINE | re.DOTALL,
)


class CodeBlock(NamedTuple):
    """A block of code in the docs: ``python`` (a script) or ``console`` (commands)."""

    where: str
    language: str
    code: str


def fence_language(info: str) -> str:
    """The language of a fence's info string: ``python`` for ```` ```python ```` and for
    MyST's ```` ```{code-block} python ````, ``{note}`` for another directive, ``""`` for none."""
    words = info.split()
    if words and words[0] in {"{code-block}", "{code}", "{code-cell}"}:
        return words[1] if len(words) > 1 else ""
    return words[0] if words else ""


def fenced_blocks(text: str, where: str) -> list[CodeBlock]:
    """Every fenced block of a Markdown text, in order, with its language, looking into
    the directives (``{note}``, ...) that hold fences of their own."""
    blocks = []
    for match in FENCE.finditer(text):
        language = fence_language(match["info"])
        body = textwrap.dedent(match["body"])
        line = text.count("\n", 0, match.start()) + 1
        if language.startswith("{") and language != "{eval-rst}":
            blocks += fenced_blocks(body, f"{where}:{line}")
        else:
            blocks.append(CodeBlock(f"{where}:{line}", language, body))
    return blocks


def console_commands(block: str) -> list[str]:
    """The commands of a console block: its lines that begin with ``$ `` (with the lines
    that a backslash continues); the lines between are output."""
    commands: list[str] = []
    continued = False
    for line in block.splitlines():
        if continued:
            commands[-1] += "\n" + line
        elif line.startswith("$ "):
            commands.append(line[2:])
        else:
            continue
        continued = line.endswith("\\")
    return commands


def docs_pages() -> list[Path]:
    """The pages of the site: every Markdown file of docs/ but the generated ones."""
    return sorted(
        page
        for page in DOCS.rglob("*.md")
        if not {"_build", "api", "_templates"} & set(page.relative_to(DOCS).parts)
    )


def docstring_examples() -> list[CodeBlock]:
    """The fenced examples of the package's docstrings, which the API pages show."""
    blocks = []
    for path in sorted(PACKAGE.rglob("*.py")):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef):
                doc = ast.get_docstring(node, clean=False)
                if doc and "```" in doc:
                    where = f"{path.relative_to(ROOT)}:{getattr(node, 'name', 'module')}"
                    blocks += fenced_blocks(inspect.cleandoc(doc), where)
    return blocks


@functools.cache
def all_blocks() -> list[CodeBlock]:
    """Every fenced block of the pages, the README and the docstrings' examples."""
    pages = [*docs_pages(), README]
    blocks = [b for page in pages for b in fenced_blocks(page.read_text(), page.name)]
    return blocks + docstring_examples()


RUNNABLE = [block for block in all_blocks() if block.language in {"python", "console"}]


def reader_env() -> dict[str, str]:
    """A reader's environment: ``python`` is this interpreter (the virtual environment's),
    headless (the test-wide settings of conftest.py), nothing of the checkout on the path."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    env["PATH"] = os.pathsep.join([str(Path(sys.executable).parent), env.get("PATH", "")])
    return env


def build(source: Path, out: Path, *options: str) -> tuple[int, str]:
    """Build the site in ``source`` into ``out`` as the docs must build: warnings are
    errors, every reference is checked; returns the exit status and every warning."""
    warnings = out.parent / f"{out.name}-warnings.txt"
    result = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "-n", "--keep-going", "-q", "-b", "html",
         "-w", str(warnings), *options, str(source), str(out)],
        capture_output=True, text=True, timeout=BUILD_TIMEOUT, env=reader_env(),
    )  # fmt: skip
    found = warnings.read_text() if warnings.exists() else ""
    # What went to stderr besides the warnings: a crash's traceback, say.
    others = [line for line in result.stderr.splitlines() if line and line not in found]
    return result.returncode, found + ("\n".join(others) if result.returncode else "")


def documented_modules() -> list[str]:
    """The modules that must each have an API page: every module of the package but the
    private ones and those that stand in for another (``python -m warehouse_phys.sweep``)."""
    names = []
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = path.relative_to(ROOT).with_suffix("").parts
        if parts[-1] == "__init__":
            parts = parts[:-1]
        elif parts[-1].startswith("_") or "sys.modules[__name__] =" in path.read_text():
            continue
        names.append(".".join(parts))
    return names


@pytest.mark.slow
def test_the_site_builds_with_no_warning_and_documents_every_module(tmp_path):
    source = tmp_path / "docs"
    shutil.copytree(DOCS, source, ignore=shutil.ignore_patterns(*NOT_COPIED))
    # One process: the suite's other workers keep the cores busy, and a parallel build
    # costs about 15 % more CPU (forked readers, environments pickled back and merged).
    status, warnings = build(source, tmp_path / "html")
    assert status == 0, f"the docs build failed (exit {status}):\n{warnings}"
    assert not warnings.strip(), warnings
    for page in docs_pages():
        assert (tmp_path / "html" / page.relative_to(DOCS).with_suffix(".html")).is_file()
    missing = [
        name
        for name in documented_modules()
        if not (tmp_path / "html" / "api" / f"{name}.html").is_file()
    ]
    assert not missing, f"modules without an API page: {missing}"


@pytest.mark.slow
def test_a_broken_reference_or_link_fails_the_build(tmp_path):
    """The site's own settings (nitpicky, warnings as errors) catch a reference to a name
    the package lacks and a link to a page the site lacks; only other projects' names pass."""
    source = tmp_path / "docs"
    shutil.copytree(DOCS, source, ignore=shutil.ignore_patterns("*.md", *NOT_COPIED))
    (source / "index.md").write_text(
        "# A page\n\n"
        "{py:func}`warehouse_phys.no_such_function` and [a page](no-such-page.md); "
        "{py:class}`numpy.ndarray` is another project's.\n"
    )
    status, warnings = build(source, tmp_path / "html")
    assert status != 0
    assert "warehouse_phys.no_such_function" in warnings
    assert "no-such-page" in warnings
    assert "numpy.ndarray" not in warnings
    page = (tmp_path / "html" / "index.html").read_text()  # written all the same (--keep-going)
    assert '<span class="pre">numpy.ndarray</span></code> is another' in page  # as text


def test_the_docs_have_examples_of_both_kinds():
    assert {"python", "console"} <= {block.language for block in RUNNABLE}
    assert len(docstring_examples()) >= 4  # the environments' examples, on the API pages


def test_every_fence_says_whether_it_runs():
    refused = [(b.where, b.language) for b in all_blocks() if b.language in REFUSED_LANGUAGES]
    assert not refused, f"fence these as python, console (with $ ) or text: {refused}"
    consoles = [b for b in all_blocks() if b.language == "console"]
    assert all(console_commands(b.code) for b in consoles), "a console block with no $ line"


def test_fenced_blocks_and_console_commands_are_read_as_the_convention_says():
    page = textwrap.dedent(
        """\
        ```python
        print(1)
        ```
        ```text
        1
        ```
        ```
        plain
        ```
        ````{note}
        ```console
        $ python -m warehouse_phys.simulate \\
            --steps 2
        output line
        $ echo done
        ```
        ````
        ```{code-block} python
        print(2)
        ```
        """
    )
    blocks = fenced_blocks(page, "page.md")
    assert [b.language for b in blocks] == ["python", "text", "", "console", "python"]
    assert blocks[0].code == "print(1)\n"
    assert console_commands(blocks[3].code) == [
        "python -m warehouse_phys.simulate \\\n    --steps 2",
        "echo done",
    ]


@pytest.mark.slow
@pytest.mark.parametrize("block", RUNNABLE, ids=[f"{b.where}-{b.language}" for b in RUNNABLE])
def test_code_block_runs_in_a_fresh_folder(block, tmp_path):
    """A python block runs as ``python example.py``, a console block's commands one after
    another, in a fresh empty folder with nothing of the checkout beside it (no ../shared)."""
    folder = tmp_path / "reader"
    folder.mkdir()
    assert "../shared" not in block.code, f"{block.where}: use the maps the package ships"
    if block.language == "python":
        (folder / "example.py").write_text(block.code)
        commands = [f'"{sys.executable}" example.py']
    else:
        commands = console_commands(block.code)
    for command in commands:
        try:
            result = subprocess.run(
                command, shell=True, cwd=folder, env=reader_env(), capture_output=True,
                text=True, timeout=BLOCK_TIMEOUT,
            )  # fmt: skip
        except subprocess.TimeoutExpired:
            pytest.fail(f"{block.where}: {command!r} ran past {BLOCK_TIMEOUT} s")
        assert result.returncode == 0, (
            f"{block.where}: {command!r} exited {result.returncode}:\n"
            f"{result.stdout[-3000:]}\n{result.stderr[-3000:]}"
        )


def test_the_readme_is_a_short_front_door_whose_links_resolve():
    text = README.read_text()
    assert len(text.splitlines()) <= README_LINES
    assert {"python", "console"} <= {b.language for b in fenced_blocks(text, "README.md")}
    # Relative links and pictures (the docs' pages, ARCHITECTURE.md, docs/*.gif) exist.
    targets = re.findall(r"\]\(([^)\s]+)\)", text)
    local = [t.split("#")[0] for t in targets if not re.match(r"[a-z]+:", t)]
    assert len(local) >= 10
    missing = [t for t in local if t and not (ROOT / t).is_file()]
    assert not missing, f"README links to files that do not exist: {missing}"
    pages = {p.relative_to(ROOT).as_posix() for p in docs_pages()}
    linked = {t for t in local if t.startswith("docs/") and t.endswith(".md")}
    assert len(linked) >= 8
    assert linked <= pages
