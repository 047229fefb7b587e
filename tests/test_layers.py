"""The package's import graph, read from the source (imports inside functions count): no import circle,
and nothing below the viewer and the command imports them (issue 23, point 1).

A package's lazy `__getattr__` re-exports and `if TYPE_CHECKING:` imports are not edges; `from . import
sibling` is an edge to the sibling, not to the package."""
from __future__ import annotations

import ast
import functools
import re
from pathlib import Path
from types import MappingProxyType

import isoscope

ROOT = Path(isoscope.__file__).parent
FRONT_ENDS = ("isoscope.viewer", "isoscope.cli", "isoscope.launch", "isoscope.__main__")


def _name(path: Path) -> str:
    parts = ["isoscope", *path.relative_to(ROOT).with_suffix("").parts]
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _skipped(tree: ast.Module) -> set[int]:
    """Nodes under `if TYPE_CHECKING:` and in a module-level `__getattr__` (lazy re-exports)."""
    skipped = set()
    for node in ast.walk(tree):
        lazy = isinstance(node, ast.FunctionDef) and node.name == "__getattr__" and node in tree.body
        if lazy or (isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test)):
            skipped.update(id(sub) for sub in ast.walk(node))
    return skipped


@functools.cache   # read once a process: the tests below only look at it
def import_graph() -> MappingProxyType[str, frozenset[str]]:
    modules = {_name(path): path for path in ROOT.rglob("*.py")}
    graph = {name: set() for name in modules}
    for name, path in modules.items():
        tree = ast.parse(path.read_text())
        skipped = _skipped(tree)
        package = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
        for node in ast.walk(tree):
            if id(node) in skipped:
                continue
            if isinstance(node, ast.Import):
                targets = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = ".".join(package[:len(package) - node.level + 1] + ([node.module] if node.module else [])) \
                    if node.level else (node.module or "")
                targets = [f"{base}.{alias.name}" if f"{base}.{alias.name}" in modules else base
                           for alias in node.names]
            else:
                continue
            graph[name].update(t for t in targets if t in modules and t != name)
    return MappingProxyType({name: frozenset(targets) for name, targets in graph.items()})


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan's algorithm, iteratively)."""
    index, low, on_stack, stack, found, counter = {}, {}, set(), [], [], 0
    for root in graph:
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
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
                index[child] = low[child] = counter
                counter += 1
                stack.append(child)
                on_stack.add(child)
                work.append((child, iter(sorted(graph[child]))))
            elif child in on_stack:
                low[node] = min(low[node], index[child])
    return found


def test_the_checker_finds_a_circle():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    assert circles(graph) == [["a", "b", "c"]]
    assert circles({"a": {"b"}, "b": set()}) == []


def test_no_import_circle():
    assert circles(import_graph()) == []


def test_only_the_front_ends_import_the_front_ends():
    graph = import_graph()
    front = [name for name in graph if name.startswith(FRONT_ENDS)]
    assert any(name.startswith("isoscope.viewer.") for name in front) and "isoscope.cli.main" in front
    wrong = sorted(f"{name} -> {target}" for name, targets in graph.items() for target in targets
                   if target.startswith(FRONT_ENDS) and not name.startswith(FRONT_ENDS))
    assert not wrong, wrong


# What each layer may import (besides itself): dependencies point one way, down.  docs/guide/how-it-works.md's layout
# section draws the same table.  Front ends (viewer, cli, launch) sit on top; the viewer never imports
# the command.
BELOW = {
    "errors": set(), "resources": {"errors"},
    "core": {"errors"},
    "options": {"core", "errors"},   # the spec reads what core decides (the topologies of its tables)
    "validation": {"core", "errors"},
    "cpu": {"core", "errors", "validation"},
    "io": {"core", "errors"},
    "gpu": {"core", "errors", "resources", "validation"},   # beside cpu, not above it: what both need is core's
    "big": {"core", "cpu", "gpu", "io", "errors", "validation"},
    "volumes": {"core", "gpu", "errors", "resources", "validation"},   # expr: samples a formula on the GPU
    "one_shot": {"core", "cpu", "gpu", "big", "options", "errors", "validation"},
    "api": {"core", "cpu", "gpu", "big", "one_shot", "options", "errors", "validation"},
    "labels": {"core", "cpu", "gpu", "io", "one_shot", "options", "errors", "validation"},
    "surface": {"core", "cpu", "gpu", "io", "volumes", "one_shot", "labels", "errors", "validation"},
}
TOP = {"viewer": {"cli", "launch", "__main__"}, "cli": {"launch", "__main__"}, "launch": {"__main__"},
       "__main__": set(), "isoscope": set()}  # a front end's forbidden layers


def layer_of(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "isoscope"


def test_every_module_has_a_layer():
    assert {layer_of(name) for name in import_graph()} <= set(BELOW) | set(TOP)


def test_dependencies_point_down():
    wrong = []
    for name, targets in import_graph().items():
        here = layer_of(name)
        for target in targets:
            there = layer_of(target)
            if there == here or there == "isoscope":
                continue
            allowed = there in BELOW[here] if here in BELOW else there not in TOP[here]
            if not allowed:
                wrong.append(f"{name} -> {target}")
    assert not wrong, sorted(wrong)


def test_the_root_stays_small_and_no_file_is_long():
    root_modules = sorted(path.name for path in ROOT.glob("*.py"))
    assert len(root_modules) <= 12, root_modules
    long = sorted(f"{path.relative_to(ROOT)}: {n}" for path in ROOT.rglob("*.py")
                  if (n := len(path.read_text().splitlines())) > 600)
    assert not long, long


GL_CALLS = re.compile(r"\.(compute_shader|program|buffer|texture3?d?|framebuffer|vertex_array)\(")


def test_gl_objects_are_made_in_the_gl_layers_only():
    """Only gpu/ and the viewer's drawing and windows make GL objects (a loader asks gpu/ to sample a formula,
    the command and the facade ask the viewer for pictures): a GL call elsewhere is work in the wrong layer."""
    places = {"gpu", "viewer"}
    found = sorted(f"{path.relative_to(ROOT)}: {match.group(0)}" for path in ROOT.rglob("*.py")
                   if path.relative_to(ROOT).parts[0] not in places
                   for match in GL_CALLS.finditer(path.read_text()))
    assert not found, found
