"""The package's structure, read from its source: no import cycle (an import inside a function counts, so none can
hide one) and no private name imported from another package."""

from __future__ import annotations

import ast
from pathlib import Path

import sightplan

ROOT = Path(sightplan.__file__).parent


def modules() -> dict[str, Path]:
    found = {}
    for path in ROOT.rglob("*.py"):
        parts = list(path.relative_to(ROOT.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        found[".".join(parts)] = path
    return found


MODULES = modules()


def discovered(name: str, tree: ast.AST) -> list[str]:
    """The modules ``name`` imports by finding them at run time: a module that calls ``pkgutil.iter_modules`` (a
    registry collecting its package's modules) imports every module of its package."""
    calls = any(isinstance(node, ast.Attribute) and node.attr == "iter_modules" for node in ast.walk(tree))
    if not calls:
        return []
    package = ".".join(name.split(".")[:-1])
    return [m for m in MODULES if m.rsplit(".", 1)[0] == package and m != name]


def imports(name: str) -> list[tuple[str, list[str]]]:
    """(imported module, names taken from it) for every import of sightplan modules in ``name``, at any level, and
    every module it finds at run time (:func:`discovered`)."""
    path = MODULES[name]
    package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
    tree = ast.parse(path.read_text())
    out: list[tuple[str, list[str]]] = [(m, []) for m in discovered(name, tree)]
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out += [(a.name, []) for a in node.names if a.name.split(".")[0] == "sightplan"]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package[: len(package) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            if target.split(".")[0] != "sightplan":
                continue
            for alias in node.names:  # `from pkg import module` imports the module
                sub = f"{target}.{alias.name}"
                out.append((sub, []) if sub in MODULES else (target, [alias.name]))
    return [(m, names) for m, names in out if m in MODULES and m != name]


def graph() -> dict[str, set[str]]:
    """Module → the modules importing it runs: those it names, and the packages above them (a package's
    ``__init__`` runs before any of its modules)."""
    edges = {}
    for name in MODULES:
        targets = set()
        for m, _ in imports(name):
            parts = m.split(".")
            targets |= {".".join(parts[:k]) for k in range(2, len(parts) + 1)}  # not the root: it imports the API
        edges[name] = targets - {name} - {".".join(name.split(".")[:k]) for k in range(1, len(name.split(".")))}
    return edges


def cycles(edges: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index, low, stack, on, found = {}, {}, [], set(), []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in sorted(edges.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return found


def test_the_cycle_finder_finds_a_cycle():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_a_registry_imports_the_modules_it_finds():
    tree = ast.parse("import pkgutil\nfor m in pkgutil.iter_modules([]): pass\n")
    found = discovered("sightplan.formats.registry", tree)
    assert "sightplan.formats.mavlink" in found and "sightplan.formats.registry" not in found
    assert discovered("sightplan.formats.registry", ast.parse("import json\n")) == []


def test_no_module_imports_itself_through_others():
    found = cycles(graph())
    assert not found, "import cycles (an import inside a function counts):\n" + "\n".join(" ↔ ".join(c) for c in found)


def test_no_private_name_is_imported_from_another_package():
    def package(module: str) -> str:
        return ".".join(module.split(".")[:2])

    crossing = [f"{name} imports {target}.{n}" for name in MODULES for target, names in imports(name) for n in names
                if n.startswith("_") and not n.startswith("__") and package(target) != package(name)]
    assert not crossing, "\n".join(crossing)


def test_no_private_member_of_another_object_is_read():
    """``x._name`` only on ``self`` or ``cls``: stages use each other's public API (engines' ray queries, say)."""
    found = []
    for name, path in MODULES.items():
        for node in ast.walk(ast.parse(path.read_text())):
            if (isinstance(node, ast.Attribute) and node.attr.startswith("_") and not node.attr.startswith("__")
                    and not (isinstance(node.value, ast.Name) and node.value.id in ("self", "cls"))):
                found.append(f"{name}:{node.lineno} .{node.attr}")
    assert not found, "\n".join(found)
