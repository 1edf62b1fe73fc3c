"""The house rules of `robot/`, read from its source with `ast`: no class longer than 500 lines, no import cycle
among its modules (of any length, lazy and type-checking imports included), never an import of `app/`, and no
object reaching into another one's private members. Each check reports every violation with where it is."""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PACKAGE = "robot"
MAX_CLASS_LINES = 500
# Names with a leading underscore that are public by design (the named-tuple API).
PUBLIC_UNDERSCORED = {"_replace", "_asdict", "_fields", "_make", "_field_defaults"}


def module_name(path: Path, root: Path) -> str:
    parts = path.relative_to(root).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def parse_package(root: Path, package: str) -> dict[str, ast.Module]:
    """Every module of the package by dotted name, parsed."""
    return {
        module_name(path, root): ast.parse(path.read_text(), str(path))
        for path in sorted((root / package).rglob("*.py"))
    }


def imported_modules(tree: ast.Module, name: str, is_package: bool) -> Iterator[tuple[str, int]]:
    """Each module `tree` imports, anywhere in it (top level, inside functions, under TYPE_CHECKING), with its line:
    `from a.b import c` names `a.b.c` when that is a module, else `a.b`."""
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            for alias in node.names:
                yield alias.name, node.lineno
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:  # relative: resolved against this module's package
                anchor = name.split(".")
                anchor = anchor[: len(anchor) - node.level + (1 if is_package else 0)]
                base = ".".join([*anchor, base] if base else anchor)
            yield base, node.lineno
            for alias in node.names:
                yield f"{base}.{alias.name}", node.lineno


def import_graph(modules: dict[str, ast.Module], root: Path) -> dict[str, dict[str, int]]:
    """module -> {module of the same package it imports: line}."""
    graph: dict[str, dict[str, int]] = {}
    for name, tree in modules.items():
        is_package = tree is not None and (root / Path(*name.split(".")) / "__init__.py").exists()
        edges: dict[str, int] = {}
        for target, line in imported_modules(tree, name, is_package):
            if target in modules and target != name:
                edges.setdefault(target, line)
        graph[name] = edges
    return graph


def import_cycles(graph: dict[str, dict[str, int]]) -> list[list[str]]:
    """The strongly connected components with more than one module (Tarjan), each as a cycle to show."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for target in graph[node]:
            if target not in index:
                visit(target)
                low[node] = min(low[node], low[target])
            elif target in on_stack:
                low[node] = min(low[node], index[target])
        if low[node] == index[node]:
            component = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                component.append(member)
                if member == node:
                    break
            if len(component) > 1:
                components.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return [_one_cycle(graph, component) for component in components]


def _one_cycle(graph: dict[str, dict[str, int]], component: list[str]) -> list[str]:
    """A cycle through the component's first module, found by walking inside the component (for the message)."""
    members = set(component)
    start = component[0]
    path, seen = [start], {start}
    while True:
        here = path[-1]
        if start in graph[here] and len(path) > 1:
            return [*path, start]
        step = next((t for t in sorted(graph[here]) if t in members and t not in seen), None)
        if step is None:  # a dead end within the component: show the component instead
            return [*component, "..."]
        path.append(step)
        seen.add(step)


def long_classes(modules: dict[str, ast.Module], limit: int = MAX_CLASS_LINES) -> list[str]:
    found = []
    for name, tree in modules.items():
        for node in ast.walk(tree):
            if isinstance(node, ast.ClassDef):
                lines = (node.end_lineno or node.lineno) - node.lineno + 1
                if lines > limit:
                    found.append(f"{name}.{node.name}: {lines} lines (line {node.lineno})")
    return found


def app_imports(modules: dict[str, ast.Module], package: str = "app") -> list[str]:
    """Every import of `package` (or one of its modules) in `modules`, with where it is."""
    found = []
    for name, tree in modules.items():
        for target, line in imported_modules(tree, name, False):
            if target == package or target.startswith(f"{package}."):
                found.append(f"{name}:{line} imports {target}")
    return found


def private_reaches(modules: dict[str, ast.Module]) -> list[str]:
    """`other._member` where `other` is not the object itself (`self`, `cls`, `super()`), and `from m import _name`:
    one object (or module) using what another keeps private."""
    found = []
    for name, tree in modules.items():
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and _private(node.attr) and not _is_own(node.value):
                found.append(f"{name}:{node.lineno} {ast.unparse(node)}")
            elif isinstance(node, ast.ImportFrom) and node.level == 0:
                found.extend(
                    f"{name}:{node.lineno} from {node.module} import {alias.name}"
                    for alias in node.names
                    if _private(alias.name)
                )
    return found


def _private(attr: str) -> bool:
    return attr.startswith("_") and not attr.startswith("__") and attr not in PUBLIC_UNDERSCORED


def _is_own(value: ast.expr) -> bool:
    if isinstance(value, ast.Name):
        return value.id in ("self", "cls")
    return isinstance(value, ast.Call) and isinstance(value.func, ast.Name) and value.func.id == "super"


@pytest.fixture(scope="module")
def modules() -> dict[str, ast.Module]:
    return parse_package(ROOT, PACKAGE)


def test_no_class_in_robot_is_longer_than_500_lines(modules) -> None:
    found = long_classes(modules)
    assert found == [], "\n".join(found)


def test_robot_modules_import_each_other_without_a_cycle(modules) -> None:
    cycles = import_cycles(import_graph(modules, ROOT))
    assert cycles == [], "\n".join(" -> ".join(cycle) for cycle in cycles)


def test_robot_never_imports_the_app(modules) -> None:
    found = app_imports(modules)
    assert found == [], "\n".join(found)


def test_the_tests_and_the_rigs_they_share_with_the_benches_never_import_the_benches() -> None:
    """The benches measure; the tests check, with the rigs in `harness/` (a bench may change without a test)."""
    found = [*app_imports(parse_package(ROOT, "tests"), "bench"), *app_imports(parse_package(ROOT, "harness"), "bench")]
    found += app_imports(parse_package(ROOT, "harness"), "tests")
    assert found == [], "\n".join(found)


def test_no_object_in_robot_reaches_into_another_ones_private_members(modules) -> None:
    found = private_reaches(modules)
    assert found == [], "\n".join(found)


# The checks themselves, on small made-up packages: each must see the violation it is for.


def _write(root: Path, files: dict[str, str]) -> dict[str, ast.Module]:
    for relative, text in files.items():
        path = root / relative
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return parse_package(root, "pkg")


def test_the_checks_find_a_three_module_cycle_a_long_class_an_app_import_and_a_private_reach(tmp_path) -> None:
    long_body = "\n".join(f"    x{i} = {i}" for i in range(MAX_CLASS_LINES))
    modules = _write(
        tmp_path,
        {
            "pkg/__init__.py": "",
            "pkg/a.py": "from pkg.b import thing\n",
            "pkg/b.py": "def thing():\n    from pkg import c\n",
            "pkg/c.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from pkg.a import x\n",
            "pkg/big.py": f"class Big:\n{long_body}\n",
            "pkg/web.py": "from app.web.main import create_app\n",
            "pkg/nosy.py": "class Nosy:\n    def peek(self, other):\n        return other._secret + self._own\n",
            "pkg/helper.py": "from pkg.a import _hidden\n",
        },
    )
    assert import_cycles(import_graph(modules, tmp_path)) == [["pkg.a", "pkg.b", "pkg.c", "pkg.a"]]
    assert long_classes(modules) == ["pkg.big.Big: 501 lines (line 1)"]
    assert app_imports(modules) == ["pkg.web:1 imports app.web.main", "pkg.web:1 imports app.web.main.create_app"]
    assert private_reaches(modules) == ["pkg.helper:1 from pkg.a import _hidden", "pkg.nosy:3 other._secret"]


def test_the_checks_pass_a_clean_package(tmp_path) -> None:
    modules = _write(
        tmp_path,
        {
            "pkg/__init__.py": "",
            "pkg/a.py": "from pkg.b import thing\n",
            "pkg/b.py": "class Thing:\n    def __init__(self):\n        self._x = 1\n        super()._y()\n",
        },
    )
    assert import_cycles(import_graph(modules, tmp_path)) == []
    assert long_classes(modules) == []
    assert app_imports(modules) == []
    assert private_reaches(modules) == []
