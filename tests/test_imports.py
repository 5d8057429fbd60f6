"""The package's import graph has no cycle, counting imports inside functions too, and follows
the layer order docs/design.md states."""

from __future__ import annotations

import ast
from pathlib import Path

import rallysim

ROOT = Path(rallysim.__file__).parent


def _module_name(path: Path) -> str:
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _runtime_nodes(tree: ast.AST):
    """Every node except those under ``if TYPE_CHECKING:`` (imports for type checkers only)."""
    for node in ast.iter_child_nodes(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            yield from (n for child in node.orelse for n in _runtime_nodes_of(child))
            continue
        yield from _runtime_nodes_of(node)


def _runtime_nodes_of(node: ast.AST):
    yield node
    yield from _runtime_nodes(node)


def _graph() -> dict[str, set[str]]:
    modules = {_module_name(p): p for p in ROOT.rglob("*.py")}
    graph: dict[str, set[str]] = {m: set() for m in modules}
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        for node in _runtime_nodes(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    base = ".".join(package.split(".")[:len(package.split(".")) - node.level + 1]
                                    + ([base] if base else []))
                targets = [base] + [f"{base}.{a.name}" for a in node.names]
            else:
                continue
            for target in targets:
                # importing a.b.c runs a and a.b first; a module's own packages are already
                # imported when it runs, so they are no dependency of it
                parts = target.split(".")
                for k in range(1, len(parts) + 1):
                    dep = ".".join(parts[:k])
                    if dep in modules and not (name + ".").startswith(dep + "."):
                        graph[name].add(dep)
    return graph


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    found, state, stack = [], {}, []

    def visit(node: str) -> None:
        state[node] = "open"
        stack.append(node)
        for dep in sorted(graph[node]):
            if state.get(dep) == "open":
                found.append([*stack[stack.index(dep):], dep])
            elif dep not in state:
                visit(dep)
        stack.pop()
        state[node] = "done"

    for node in sorted(graph):
        if node not in state:
            visit(node)
    return found


def test_type_checking_imports_are_not_runtime_imports():
    tree = ast.parse("import a\nif TYPE_CHECKING:\n    import b\nelse:\n    import c\n"
                     "def f():\n    import d\n")
    names = [n.names[0].name for n in _runtime_nodes(tree) if isinstance(n, ast.Import)]
    assert names == ["a", "c", "d"]


def test_the_cycle_finder_finds_a_cycle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == [["a", "b", "c", "a"]]
    assert _cycles({"a": {"b"}, "b": set()}) == []


def test_no_import_cycle_at_module_or_function_level():
    graph = _graph()
    assert "rallysim.core.game" in graph["rallysim.core.tasks.rally"]  # the finder sees imports
    assert _cycles(graph) == []


def _layers() -> list[list[str]]:
    """The layers docs/design.md states, lowest first: each a list of module prefixes (a line
    of its layer block: the names before the description, comma-separated, a parenthesis
    left out)."""
    text = (ROOT.parents[1] / "docs" / "design.md").read_text()
    block = text.split("Layers, each importing only those below it", 1)[1]
    block = block.split("```", 2)[1]
    layers = []
    for line in block.strip().splitlines():
        names = line.split("  ")[0].split("(")[0]
        layers.append([n.strip() for n in names.replace(",", " ").split() if n.strip()])
    return layers[::-1]


def _layer_of(module: str, layers: list[list[str]]) -> int | None:
    """The layer of ``rallysim.<module>``: that of the longest prefix naming it."""
    name = module.removeprefix("rallysim.")
    best, level = -1, None
    for k, prefixes in enumerate(layers):
        for prefix in prefixes:
            if (name == prefix or name.startswith(prefix + ".")) and len(prefix) > best:
                best, level = len(prefix), k
    return level


# the one import up that docs/design.md states: an env's frames drawn by the renderer
UPWARD = {"rallysim.envs.rendering": "rallysim.render"}


def test_every_import_follows_the_layer_order_the_design_states():
    layers = _layers()
    assert layers[0] == ["core"] and layers[-1] == ["cli"]
    graph = _graph()
    wrong = []
    for module, deps in graph.items():
        here = _layer_of(module, layers)
        for dep in deps:
            there = _layer_of(dep, layers)
            allowed = UPWARD.get(module)
            if allowed and (dep == allowed or dep.startswith(allowed + ".")):
                continue
            if here is not None and there is not None and there > here:
                wrong.append(f"{module} -> {dep}")
    assert wrong == [], wrong
