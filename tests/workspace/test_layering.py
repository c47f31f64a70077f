"""The workspace's structure, checked from its source: packages import only the packages below them on the
data path (imports inside functions count), each package.xml declares the project packages its code
imports, an import inside a function says why on its line or the line above, and no source file is long.
"""
from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SRC = ROOT / "ros2_ws" / "src"
# The data path, bottom to top: a package may import those before it, never one after it.
LAYERS = ("foos_core", "foos_bag", "foos_sim", "foos_vision", "foos_calibration", "foos_policy", "foos_viewer")
MAX_LINES = 700


def python_files(package: str) -> list[Path]:
    return sorted((SRC / package / package).rglob("*.py"))


def imports(path: Path) -> list[tuple[str, int, bool]]:
    """(top-level module, line, at module level) of every import in the file."""
    tree = ast.parse(path.read_text(), str(path))
    top_level = {id(node) for node in tree.body}
    for node in tree.body:  # `if TYPE_CHECKING:` / `try:` blocks at module level count as module level
        if isinstance(node, (ast.If, ast.Try)):
            top_level.update(id(n) for n in ast.walk(node))
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found += [(alias.name.split(".")[0], node.lineno, id(node) in top_level) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.append((node.module.split(".")[0], node.lineno, id(node) in top_level))
        elif isinstance(node, ast.ImportFrom):
            found.append(("", node.lineno, id(node) in top_level))
    return found


def declared(package: str) -> set[str]:
    xml = (SRC / package / "package.xml").read_text()
    return set(re.findall(r"<(?:exec_)?depend>(foos_\w+)</(?:exec_)?depend>", xml))


def test_every_package_is_on_the_data_path():
    assert sorted(p.name for p in SRC.iterdir() if (p / "package.xml").is_file()) == sorted(LAYERS)


@pytest.mark.parametrize("package", LAYERS)
def test_a_package_imports_only_the_packages_below_it_and_declares_them(package):
    allowed = set(LAYERS[: LAYERS.index(package)])
    used, wrong = set(), []
    for path in python_files(package):
        for module, line, _ in imports(path):
            if module.startswith("foos_") and module != package:
                used.add(module)
                if module not in allowed:
                    wrong.append(f"{path.relative_to(ROOT)}:{line} imports {module}")
    assert not wrong, "imports against the data path:\n" + "\n".join(wrong)
    assert used <= declared(package), f"{package}/package.xml does not declare {sorted(used - declared(package))}"


@pytest.mark.parametrize("package", LAYERS)
def test_an_import_inside_a_function_says_why(package):
    unexplained = []
    for path in python_files(package):
        lines = path.read_text().splitlines()
        for _, line, at_top in imports(path):
            if not at_top and "#" not in lines[line - 1] and not lines[line - 2].strip().startswith("#"):
                unexplained.append(f"{path.relative_to(ROOT)}:{line}: {lines[line - 1].strip()}")
    assert not unexplained, "imports inside functions without a comment saying why:\n" + "\n".join(unexplained)


def test_no_source_file_is_over_700_lines():
    files = [p for p in SRC.rglob("*.py") if "/build/" not in str(p)]
    files += list((ROOT / "tests").rglob("*.py")) + [p for p in (ROOT / "scripts").iterdir() if p.is_file()]
    long = [f"{p.relative_to(ROOT)}: {n}" for p in files if (n := len(p.read_text().splitlines())) > MAX_LINES]
    assert not long, f"source files over {MAX_LINES} lines:\n" + "\n".join(long)


def module_name(package: str, path: Path) -> str:
    """The module's dotted name inside its package: '' for the package's __init__, 'camera.live' in a subpackage."""
    parts = list(path.relative_to(SRC / package / package).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def intra_package_imports(package: str) -> dict[str, dict[str, int]]:
    """module -> {module of the same package it imports: line}, with imports at any depth (in functions, under
    `if TYPE_CHECKING:`), relative or absolute."""
    paths = {module_name(package, path): path for path in python_files(package)}
    graph: dict[str, dict[str, int]] = {name: {} for name in paths}
    for name, path in paths.items():
        own_package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
        own_package = [p for p in own_package if p]
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.ImportFrom) and node.level:
                base = own_package[: len(own_package) - (node.level - 1)]
                target = base + (node.module.split(".") if node.module else [])
            elif isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == package:
                target = node.module.split(".")[1:]
            elif isinstance(node, ast.Import):
                for alias in node.names:
                    if alias.name.split(".")[0] == package and ".".join(alias.name.split(".")[1:]) in paths:
                        graph[name].setdefault(".".join(alias.name.split(".")[1:]), node.lineno)
                continue
            else:
                continue
            names = [alias.name for alias in node.names]
            submodules = [".".join(target + [n]) for n in names if ".".join(target + [n]) in paths]
            for imported in submodules or [".".join(target)]:
                if imported in paths and imported != name:
                    graph[name].setdefault(imported, node.lineno)
    return graph


def import_cycles(graph: dict[str, dict[str, int]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan), each in a stable order."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    cycles = []

    def visit(node: str):
        index[node] = low[node] = len(index)
        stack.append(node)
        for nxt in sorted(graph[node]):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            component = []
            while not component or component[-1] != node:
                component.append(stack.pop())
            if len(component) > 1:
                cycles.append(sorted(component))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return cycles


@pytest.mark.parametrize("package", LAYERS)
def test_no_circle_of_imports_inside_a_package(package):
    graph = intra_package_imports(package)
    cycles = import_cycles(graph)
    described = [", ".join(f"{m} (imports {sorted(set(graph[m]) & set(c))})" for m in c) for c in cycles]
    assert not cycles, f"{package}: modules that import each other in a circle:\n" + "\n".join(described)


def test_the_circle_check_sees_imports_at_any_depth():
    graph = {"a": {"b": 1}, "b": {"c": 2}, "c": {"a": 3}, "d": {"a": 4}}
    assert import_cycles(graph) == [["a", "b", "c"]] and import_cycles({"a": {"b": 1}, "b": {}}) == []


# foos_vision's stages, in the order a frame flows: a module imports only those of its own stage or a lower one
# (errors, the package's exceptions, lies under them all; the shells, at the package's top level, over them all).
VISION_STAGES = ("errors", "camera", "detection", "tracking")


def vision_stage(module: str) -> int:
    """The stage's rank of a foos_vision module: its subpackage's place in VISION_STAGES; a top-level module other
    than errors (or the package's __init__) is a shell, above every stage."""
    first = module.split(".")[0]
    return VISION_STAGES.index(first) if first in VISION_STAGES else len(VISION_STAGES)


def imports_up_a_stage(graph: dict[str, dict[str, int]], stage) -> list[str]:
    return [f"{module}:{line} imports {imported}" for module, targets in sorted(graph.items())
            for imported, line in sorted(targets.items()) if stage(imported) > stage(module)]


def test_vision_stages_import_only_their_own_or_lower_stages():
    graph = intra_package_imports("foos_vision")
    assert {m.split(".")[0] for m in graph if "." in m} == set(VISION_STAGES[1:])  # the stages are there
    wrong = imports_up_a_stage(graph, vision_stage)
    assert not wrong, "foos_vision: imports up a stage (errors < camera < detection < tracking < shells):\n" + \
        "\n".join(wrong)


def test_the_stage_check_sees_an_import_up_a_stage():
    graph = {"camera.geometry": {"errors": 1}, "detection.ball_search": {"tracking.velocity": 2},
             "track_cli": {"tracking.tracker": 3}, "errors": {}, "tracking.velocity": {}, "tracking.tracker": {}}
    assert imports_up_a_stage(graph, vision_stage) == ["detection.ball_search:2 imports tracking.velocity"]
