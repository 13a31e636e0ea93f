"""The package's Python modules form layers: no module imports another that imports it back,
directly or through others (the Rust sources are held to the same by tests/layers.rs).

Every import of a module of the package counts, wherever it is written (inside a function
too): `from . import x`, `from .x import y`, `from implicitize import x`, `import
implicitize.x`. Importing the package itself (`from . import name` of a name its
`__init__.py` defines, `import implicitize`) is an edge to `__init__`."""

from __future__ import annotations

import ast
from pathlib import Path

import implicitize

PACKAGE = "implicitize"


def modules(folder: Path) -> dict[str, Path]:
    """The package's Python modules by name (`__init__` for the package)."""
    return {path.stem: path for path in sorted(folder.glob("*.py"))}


def extensions(folder: Path) -> set[str]:
    """The package's compiled modules (`_implicitize`): they import nothing of it."""
    return {
        path.name.split(".")[0]
        for path in folder.iterdir()
        if path.suffix in (".so", ".pyd") and path.name.split(".")[0].isidentifier()
    }


def imported(tree: ast.AST, known: set[str]) -> set[str]:
    """The package's modules that the source's imports name."""
    named = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                parts = alias.name.split(".")
                if parts[0] == PACKAGE:
                    named.add(parts[1] if len(parts) > 1 and parts[1] in known else "__init__")
        elif isinstance(node, ast.ImportFrom):
            inside = node.level == 1 and node.module is None
            from_package = node.level == 0 and node.module == PACKAGE
            if inside or from_package:
                for alias in node.names:
                    named.add(alias.name if alias.name in known else "__init__")
                continue
            module = node.module or ""
            if node.level == 1:
                name = module.split(".")[0]
            elif module.startswith(PACKAGE + "."):
                name = module.split(".")[1]
            else:
                continue
            named.add(name if name in known else "__init__")
    return named


def graph(sources: dict[str, str], compiled: set[str] = frozenset()) -> dict[str, set[str]]:
    """Each module's edges to the package's modules it imports (Python or `compiled`)."""
    known = set(sources) | set(compiled)
    return {
        name: imported(ast.parse(text), known) - {name} for name, text in sources.items()
    }


def cycle(edges: dict[str, set[str]]) -> list[str] | None:
    """A cycle of the graph, the first module repeated at its end, if there is one."""
    state: dict[str, int] = {}
    path: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        path.append(node)
        for target in sorted(edges.get(node, ())):
            if state.get(target) == 1:
                return path[path.index(target):] + [target]
            if target not in state:
                found = visit(target)
                if found:
                    return found
        path.pop()
        state[node] = 2
        return None

    for node in sorted(edges):
        if node not in state:
            found = visit(node)
            if found:
                return found
    return None


def test_the_package_has_no_import_cycle():
    folder = Path(implicitize.__file__).parent
    sources = {name: path.read_text() for name, path in modules(folder).items()}
    compiled = extensions(folder)
    assert {"__init__", "batch"} <= set(sources) and "_implicitize" in compiled, sorted(sources)
    edges = graph(sources, compiled)
    assert edges["batch"] == {"_implicitize"}, edges
    assert cycle(edges) is None, f"the package's modules import each other in a cycle: {cycle(edges)}"


def test_a_cycle_is_found_and_named():
    sources = {
        "__init__": "from .a import thing\n",
        "a": "def f():\n    from . import b\nthing = 1\n",
        "b": "import implicitize.a\n",
        "c": "from implicitize import b\n",
    }
    edges = graph(sources)
    assert edges["__init__"] == {"a"} and edges["a"] == {"b"} and edges["c"] == {"b"}
    assert cycle(edges) == ["a", "b", "a"]
    sources["b"] = "import numpy\n"
    assert cycle(graph(sources)) is None


def test_importing_a_name_of_the_package_is_an_edge_to_its_init():
    edges = graph({"__init__": "X = 1\n", "batch": "from . import X, _ext\n"}, {"_ext"})
    assert edges["batch"] == {"__init__", "_ext"}
    assert cycle(edges) is None
