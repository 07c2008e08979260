"""The API reference's machinery: what each module's page shows, read from the package's
source, and the few corrections autodoc and napoleon need for this package's docstrings.

- :func:`api_modules`: for the module template (_templates/autosummary/module.rst), every
  name a module defines, in source order (its constants included, documented or not: autodoc
  alone shows only those with a ``#:`` comment), the names a package re-exports, and its
  submodules; nothing has to be kept in step with the package by hand.
- :func:`resolve_the_python_way`: a reference resolves as the name would in Python: a name
  the module imports (``:class:`WarehouseGrid``` in a module that imports it), a public
  path through a package that re-exports it (``warehouse_phys.physics.PhysicsConfig``), a
  method a class inherits (``:meth:`render```). Nothing else is let through: a name that
  is neither documented nor imported still fails the build.
- :func:`qualify_module_references`: a module docstring's references are made full, for
  its first sentence is shown in its package's table of modules too.
- :func:`markdown_blocks`: the Markdown headings, tables and examples of the environments'
  docstrings (Gymnasium's sections: Description, Action Space, ...) read as such.
- :func:`no_type_docstrings`: a constant without a doc comment shows no docstring (not
  its type's, ``dict.__doc__``).
- :func:`napoleon_without_inline_types`: a constant's ``#: Time limit [steps]: ...`` is
  not read as the type ``Time limit [steps]``.
- :func:`dataclass_factories`: a dataclass field's ``default_factory`` reads ``list()``.
- :class:`IgnoredReferencesAsText`: a reference that ``nitpick_ignore_regex`` lets through
  (another project's name, a builtin) is left as text before Sphinx looks for it: no
  other project's inventory is loaded, so it cannot resolve, and looking costs a search
  through every name of the package per reference (a tenth of the site's build).
"""

from __future__ import annotations

import ast
import dataclasses
import importlib
import re
from functools import cache
from pathlib import Path

from docutils import nodes
from sphinx import addnodes
from sphinx.application import Sphinx
from sphinx.environment import BuildEnvironment
from sphinx.ext import napoleon
from sphinx.transforms.post_transforms import ReferencesResolver, SphinxPostTransform

PACKAGE_NAME = "warehouse_phys"

#: The nodes of a value short and plain enough to show beside its name (``= 64``):
#: literals and arithmetic on them, not calls (whose repr can run to pages).
_LITERAL_NODES = (
    ast.Constant, ast.Tuple, ast.List, ast.Set, ast.Dict, ast.UnaryOp, ast.BinOp,
    ast.operator, ast.unaryop, ast.expr_context,
)  # fmt: skip
#: Longest value shown beside its name [characters].
_LONGEST_VALUE = 80


def _is_type_checking(node: ast.AST) -> bool:
    return isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)


def _blocks(node: ast.If | ast.With | ast.Try) -> list[list[ast.stmt]]:
    """The statements a compound statement runs, block by block."""
    if isinstance(node, ast.Try):
        return [node.body, *(handler.body for handler in node.handlers), node.orelse]
    return [node.body, getattr(node, "orelse", [])]


def _shows_value(value: ast.expr | None) -> bool:
    return (
        value is not None
        and all(isinstance(node, _LITERAL_NODES) for node in ast.walk(value))
        and len(ast.unparse(value)) <= _LONGEST_VALUE
    )


def _defined_names(body: list[ast.stmt]) -> dict[str, tuple[str, bool]]:
    """The public names a module body defines, in source order, each with its kind
    (``function``, ``class`` or ``data``) and, for data, whether its value is shown; not
    the names it imports, nor those defined only for type checkers."""
    names: dict[str, tuple[str, bool]] = {}
    for node in body:
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            names.setdefault(node.name, ("function", False))
        elif isinstance(node, ast.ClassDef):
            names.setdefault(node.name, ("class", False))
        elif isinstance(node, ast.Assign | ast.AnnAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for target in targets:
                for element in target.elts if isinstance(target, ast.Tuple) else [target]:
                    if isinstance(element, ast.Name):  # a, b = 4, 5 too
                        names.setdefault(element.id, ("data", _shows_value(node.value)))
        elif isinstance(node, ast.If | ast.With | ast.Try) and not _is_type_checking(node):
            for part in _blocks(node):
                names = _defined_names(part) | names
    return {name: kind for name, kind in names.items() if not name.startswith("_")}


def _is_documented(statement: ast.stmt, following: ast.stmt | None, source: list[str]) -> bool:
    """Whether an assignment has a doc comment (``#:`` before it or after it on its line)
    or a docstring after it, as autodoc reads them."""
    before = source[statement.lineno - 2].strip() if statement.lineno > 1 else ""
    after_code = source[statement.lineno - 1].partition("#:")[1]
    docstring_after = (
        isinstance(following, ast.Expr)
        and isinstance(following.value, ast.Constant)
        and isinstance(following.value.value, str)
    )
    return before.startswith("#:") or bool(after_code) or docstring_after


def _attributes_section(docstring: str) -> set[str]:
    """The names a Google-style ``Attributes:`` section documents (napoleon's)."""
    names: set[str] = set()
    lines = docstring.splitlines()
    for i, line in enumerate(lines):
        if line.strip() != "Attributes:":
            continue
        indent = None
        for entry in lines[i + 1 :]:
            if not entry.strip():
                continue
            depth = len(entry) - len(entry.lstrip())
            if depth <= len(line) - len(line.lstrip()):
                break
            indent = depth if indent is None else indent
            if depth == indent:
                names |= {n.strip() for n in entry.split(":")[0].split("(")[0].split(",")}
    return names


def _instance_attributes(cls: ast.ClassDef, source: list[str]) -> list[str]:
    """The public attributes a class's methods set on ``self`` without a doc comment and
    that its body does not define: autodoc knows nothing of them, so the class's page
    lists them by name (the class docstring says what they are), and a reference to one
    resolves. Those with a doc comment autodoc documents itself."""
    in_body = set(_defined_names(cls.body)) | _attributes_section(ast.get_docstring(cls) or "")
    for node in cls.body:
        if isinstance(node, ast.Assign) and any(
            isinstance(t, ast.Name) and t.id == "__slots__" for t in node.targets
        ):
            in_body |= set(ast.literal_eval(node.value))
    names: dict[str, bool] = {}
    for method in cls.body:
        if not isinstance(method, ast.FunctionDef) or not method.args.args:
            continue
        self_name = method.args.args[0].arg
        statements = [n for n in ast.walk(method) if isinstance(n, ast.stmt)]
        for i, node in enumerate(statements):
            if not isinstance(node, ast.Assign | ast.AnnAssign):
                continue
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            following = statements[i + 1] if i + 1 < len(statements) else None
            # autodoc documents the annotated ones (self.x: T = ...) itself.
            documented = isinstance(node, ast.AnnAssign) or _is_documented(node, following, source)
            for target in targets:
                for element in target.elts if isinstance(target, ast.Tuple) else [target]:
                    if (
                        isinstance(element, ast.Attribute)
                        and isinstance(element.value, ast.Name)
                        and element.value.id == self_name
                    ):
                        names[element.attr] = names.get(element.attr, False) or documented
    return [
        name
        for name, documented in names.items()
        if not documented and not name.startswith("_") and name not in in_body
    ]


def _imported_names(body: list[ast.stmt]) -> dict[str, str]:
    """Name -> the full name it is imported as (``from a.b import c as d``: d -> a.b.c),
    at the top of a module (in its ``if``, ``with`` and ``try`` blocks too)."""
    names = {}
    for node in body:
        if isinstance(node, ast.ImportFrom) and node.module:
            for alias in node.names:
                names[alias.asname or alias.name] = f"{node.module}.{alias.name}"
        elif isinstance(node, ast.If | ast.With | ast.Try):
            for part in _blocks(node):
                names |= _imported_names(part)
    return names


def _root() -> Path:
    return Path(importlib.import_module(PACKAGE_NAME).__file__).resolve().parent


def main_modules() -> list[str]:
    """The package's ``__main__`` modules, which run their command when imported: for
    :confval:`autodoc_mock_imports`, so that autosummary, which imports every submodule of
    a package it documents, skips them."""
    return [
        ".".join(path.relative_to(_root().parent).with_suffix("").parts)
        for path in sorted(_root().rglob("__main__.py"))
    ]


@cache
def _package() -> tuple[dict[str, Path], dict[str, ast.Module]]:
    """Every module of the package that has a page, with its parsed source: not the
    private ones (``_moved``, ``__main__``), nor the small modules that ``python -m
    warehouse_phys.<command>`` runs, which stand in for a module documented elsewhere (they
    replace themselves in ``sys.modules``)."""
    paths = {}
    for path in sorted(_root().rglob("*.py")):
        parts = path.relative_to(_root().parent).with_suffix("").parts
        private = parts[-1].startswith("_") and parts[-1] != "__init__"
        if private or "sys.modules[__name__] =" in path.read_text():
            continue
        paths[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return paths, {name: ast.parse(path.read_text()) for name, path in paths.items()}


@cache
def _defined() -> dict[str, dict[str, tuple[str, bool]]]:
    return {name: _defined_names(tree.body) for name, tree in _package()[1].items()}


@cache
def _imported() -> dict[str, dict[str, str]]:
    return {name: _imported_names(tree.body) for name, tree in _package()[1].items()}


def home(full_name: str) -> str | None:
    """Where the object a full name reaches is defined (``warehouse_phys.physics.PhysicsConfig``
    -> ``warehouse_phys.physics.config.PhysicsConfig``), attributes and methods kept; None
    for a name the package neither defines nor imports."""
    parts = full_name.split(".")
    for cut in range(len(parts) - 1, 0, -1):  # the longest module name first
        module, name, rest = ".".join(parts[:cut]), parts[cut], parts[cut + 1 :]
        if module not in _defined():
            continue
        if name in _defined()[module] or ".".join([module, name]) in _defined():
            return full_name
        further = _imported()[module].get(name)
        if further is None or not further.startswith(f"{PACKAGE_NAME}."):
            return None
        reached = ".".join([further, *rest])
        return None if reached == full_name else home(reached)  # a module importing itself
    return None


def api_modules() -> dict[str, dict[str, list]]:
    """Per module: ``members`` (each name it defines: name, kind, whether the value is
    shown, the undocumented attributes a class sets on its instances), ``reexports`` (the
    full names of the names in its ``__all__`` that it imports) and ``submodules`` (of a
    package, named from it, as autosummary wants them)."""
    paths, trees = _package()
    pages = {}
    for name, tree in trees.items():
        exported = next(
            (
                ast.literal_eval(node.value)
                for node in tree.body
                if isinstance(node, ast.Assign)
                and any(isinstance(t, ast.Name) and t.id == "__all__" for t in node.targets)
            ),
            [],
        )
        reexports = [home(f"{name}.{n}") for n in exported if n not in _defined()[name]]
        source = paths[name].read_text().splitlines()
        attributes = {
            node.name: _instance_attributes(node, source)
            for node in ast.walk(tree)
            if isinstance(node, ast.ClassDef)
        }
        pages[name] = {
            "members": [(n, *kind, attributes.get(n, [])) for n, kind in _defined()[name].items()],
            "reexports": [full for full in reexports if full],
            "submodules": [
                sub.removeprefix(f"{name}.") for sub in paths if sub.rpartition(".")[0] == name
            ],
        }
    return pages


def type_checking_aliases() -> dict[str, str]:
    """Make the annotations that use names imported for type checkers only
    (``if TYPE_CHECKING:``) evaluable. With the whole package imported, each such name of
    the package is set in its module (there is no import circle left to fear); the names
    of the optional extras, which the build must not import, are returned as the full
    names of what they are, for :confval:`autodoc_type_aliases`."""
    aliases = {}
    for name, tree in _package()[1].items():
        for node in tree.body:
            if not _is_type_checking(node):
                continue
            for local, full_name in _imported_names(node.body).items():
                if not full_name.startswith(f"{PACKAGE_NAME}."):
                    aliases[local] = full_name
                    continue
                source, _, attribute = full_name.rpartition(".")
                value = getattr(importlib.import_module(source), attribute)
                setattr(importlib.import_module(name), local, value)
    return aliases


def _inherited(module: str, cls: str, target: str) -> str | None:
    """The full name of ``target``, a member that the class ``module.cls`` inherits from a
    class of the package, where that class defines it."""
    try:
        subject = getattr(importlib.import_module(module), cls.split(".")[0])
    except (ImportError, AttributeError):
        return None
    member = target.split(".")[0]
    for base in getattr(subject, "__mro__", ())[1:]:
        if member in vars(base) and base.__module__.startswith(f"{PACKAGE_NAME}."):
            return f"{base.__module__}.{base.__qualname__}.{target}"
    return None


def resolve_the_python_way(
    app: Sphinx, env: BuildEnvironment, node: nodes.Element, contnode: nodes.Element
) -> nodes.Element | None:
    """Resolve a Python reference that Sphinx could not as the name would resolve in the
    module it is written in (see the module's docstring)."""
    if node.get("refdomain") != "py":
        return None
    target = node["reftarget"].removeprefix("~").removeprefix(".")
    module, cls = node.get("py:module") or "", node.get("py:class") or ""
    candidates = [target, _in_scope(module, target)]
    if cls:
        candidates.append(_inherited(module, cls, target))
        if f"{module}.{cls}".rpartition(".")[0] != module:  # a nested class's outer class
            candidates.append(_inherited(module, cls.rpartition(".")[0], target))
    domain = env.get_domain("py")
    for candidate in filter(None, candidates):
        full_name = home(candidate)
        if full_name is None or full_name == target:
            continue
        resolved = domain.resolve_xref(
            env, node["refdoc"], app.builder, node["reftype"], full_name, node, contnode
        )
        if resolved is not None:
            return resolved
    return None


_HEADING = re.compile(r"^(\s*)#{1,6} +(\S.*)$")
_FENCE = re.compile(r"^(\s*)```(\w*)\s*$")
_TABLE_RULE = re.compile(r"^\s*\|[-:| ]+\|\s*$")


def _table_cells(line: str) -> list[str]:
    return [cell.strip() for cell in line.strip().strip("|").split("|")]


def markdown_blocks(
    app: Sphinx, what: str, name: str, obj: object, options: object, lines: list[str]
) -> None:
    """The Markdown blocks of a docstring written as Gymnasium writes its environments'
    (``## Action Space`` headings, pipe tables, fenced examples) in reStructuredText, in
    place: a heading becomes a rubric, a table a list-table, a fence a code block. Inline
    markup is reStructuredText's in every docstring (``literal``, :class:`...`)."""
    result: list[str] = []
    i = 0
    while i < len(lines):
        line = lines[i]
        heading, fence = _HEADING.match(line), _FENCE.match(line)
        if heading:
            result += ["", f"{heading[1]}.. rubric:: {heading[2]}", ""]
        elif fence and fence[2]:
            indent, end = fence[1], i + 1
            while end < len(lines) and not _FENCE.match(lines[end]):
                end += 1
            code = [f"{indent}   {text.removeprefix(indent)}" for text in lines[i + 1 : end]]
            result += ["", f"{indent}.. code-block:: {fence[2]}", "", *code, ""]
            i = end
        elif (
            line.lstrip().startswith("|") and i + 1 < len(lines) and _TABLE_RULE.match(lines[i + 1])
        ):
            indent = line[: len(line) - len(line.lstrip())]
            rows, end = [_table_cells(line)], i + 2
            while end < len(lines) and lines[end].lstrip().startswith("|"):
                rows.append(_table_cells(lines[end]))
                end += 1
            result += ["", f"{indent}.. list-table::", f"{indent}   :header-rows: 1", ""]
            for row in rows:
                result += [f"{indent}   * - {row[0]}", *(f"{indent}     - {c}" for c in row[1:])]
            result.append("")
            i = end - 1
        else:
            result.append(line)
        i += 1
    lines[:] = result


_ROLE = re.compile(
    r":(?:py:)?(func|meth|class|attr|data|const|obj|exc|mod):`(?:([^`<]*?)\s*<([^`>]+)>|([^`]+))`"
)


def _in_scope(module: str, target: str) -> str | None:
    """The full name of ``target`` as written in ``module``: a name it defines or imports,
    followed by attributes (``WarehouseGrid.move``)."""
    first, _, rest = target.partition(".")
    if first in _defined().get(module, {}):
        full_name = f"{module}.{target}"
    elif first in _imported().get(module, {}):
        full_name = ".".join(filter(None, [_imported()[module][first], rest]))
    else:
        full_name = target
    return home(full_name)


def qualify_module_references(
    app: Sphinx, what: str, name: str, obj: object, options: object, lines: list[str]
) -> None:
    """A module docstring's references, made full (``:func:`fleet_map_frame``` ->
    ``:func:`~warehouse_phys.drawing.map_frames.fleet_map_frame```): its first sentence is
    also shown in its package's table of modules, outside the module's scope."""
    if what != "module":
        return

    def qualify(match: re.Match[str]) -> str:
        role, title, explicit, plain = match.groups()
        target = (explicit or plain).removeprefix("~").removeprefix(".")
        full_name = _in_scope(name, target)
        if full_name is None or full_name == target:
            return match[0]
        if title:
            return f":py:{role}:`{title} <{full_name}>`"
        if "." in target and not plain.startswith("~"):
            return f":py:{role}:`{target} <{full_name}>`"
        return f":py:{role}:`~{full_name}`"

    lines[:] = [_ROLE.sub(qualify, line) for line in lines]


def no_type_docstrings(
    app: Sphinx, what: str, name: str, obj: object, options: object, lines: list[str]
) -> None:
    """A constant without a doc comment gets no docstring, rather than its type's (a dict
    would be documented by ``dict.__doc__``)."""
    type_doc = type(obj).__doc__
    if what in {"data", "attribute"} and lines and isinstance(type_doc, str):
        text = [line.strip() for line in lines if line.strip()]
        if text == [line.strip() for line in type_doc.splitlines() if line.strip()]:
            lines.clear()


def napoleon_without_inline_types(
    app: Sphinx, what: str, name: str, obj: object, options: object, lines: list[str]
) -> None:
    """Napoleon, except that an attribute's, a constant's or a property's first line is not
    read as ``type: description``: ours say ``Time limit [steps]: ...``, a unit, not a type."""
    inline = what in {"attribute", "data", "property"}
    napoleon._process_docstring(app, "object" if inline else what, name, obj, options, lines)


def dataclass_factories(
    app: Sphinx, what: str, name: str, obj: object, options: object, signature: str | None,
    return_annotation: str | None,
) -> tuple[str | None, str | None]:  # fmt: skip
    """A dataclass field's ``default_factory`` as a call (``= list()``), not as
    ``<factory>``, which is not Python and breaks the signature's parsing."""
    if signature and "<factory>" in signature and dataclasses.is_dataclass(obj):
        for field in dataclasses.fields(obj):
            if field.default_factory is not dataclasses.MISSING:
                factory = getattr(field.default_factory, "__qualname__", "factory")
                pattern = rf"\b({field.name}\b[^=]*=\s*)<factory>"
                signature = re.sub(pattern, rf"\g<1>{factory}()", signature)
    return signature, return_annotation


class IgnoredReferencesAsText(SphinxPostTransform):
    """Leave every Python reference that ``nitpick_ignore_regex`` ignores as its text,
    just as Sphinx leaves it when it finds nothing, but before Sphinx searches for it:
    a reference in a signature or a field list (``numpy.ndarray``, ``int``) is searched
    for by the ends of every name the site documents, and finds nothing, since the site
    loads no other project's inventory."""

    default_priority = ReferencesResolver.default_priority - 1

    def run(self, **kwargs: object) -> None:
        ignored = [(re.compile(kind), re.compile(target))
                   for kind, target in self.config.nitpick_ignore_regex]  # fmt: skip
        for node in list(self.document.findall(addnodes.pending_xref)):
            if node.get("refdomain") != "py" or not node.children:
                continue
            if isinstance(node[0], addnodes.pending_xref_condition):
                continue  # text that depends on whether it resolves: Sphinx's to choose
            kind, target = f"py:{node['reftype']}", node["reftarget"]
            if any(k.fullmatch(kind) and t.fullmatch(target) for k, t in ignored):
                node.replace_self(node[0].deepcopy())


def setup(app: Sphinx) -> dict[str, object]:
    """Connect the corrections; napoleon (loaded before) gives its place to
    :func:`napoleon_without_inline_types`."""
    app.setup_extension("sphinx.ext.napoleon")
    for listener in list(app.events.listeners["autodoc-process-docstring"]):
        if listener.handler is napoleon._process_docstring:
            app.disconnect(listener.id)
    app.connect("autodoc-process-docstring", no_type_docstrings, priority=300)  # first
    app.connect("autodoc-process-docstring", markdown_blocks, priority=400)
    app.connect("autodoc-process-docstring", qualify_module_references, priority=400)
    app.connect("autodoc-process-docstring", napoleon_without_inline_types)
    app.connect("autodoc-process-signature", dataclass_factories)
    app.connect("missing-reference", resolve_the_python_way)
    app.add_post_transform(IgnoredReferencesAsText)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
