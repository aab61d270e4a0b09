"""The package's architecture, checked: no import cycles, and imports only
run one way, cli -> report -> identify/control -> sim -> model/data ->
_core (docs/architecture.md). Lazy imports inside functions count too: a
cycle hidden in a function is still a cycle."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "python" / "hpctl"

#: The layer of each subpackage (or top-level module): a module may import
#: from lower layers and from its own subpackage only.
LAYERS: dict[str, int] = {
    # Generated from the core's effect tables; imports nothing of hpctl.
    "_effect_params": -1,
    "_core": 0,
    "_coretypes": 0,
    "_version": 0,
    "errors": 1,
    "caveats": 1,
    "model": 2,
    "data": 2,
    "sim": 3,
    "control": 4,
    "identify": 4,
    "vehicle": 5,
    "interop": 5,
    "hil": 5,
    "report": 6,
    "cli": 7,
    "__main__": 8,
}


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _modules() -> dict[str, Path]:
    return {_module_name(p): p for p in PACKAGE.rglob("*.py")}


def _imports(path: Path, modules: dict[str, Path]) -> set[str]:
    """The hpctl modules that ``path`` imports (at any depth of the file)."""
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.startswith("hpctl")}
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("hpctl") and node.level == 0:
            for a in node.names:
                # `from hpctl.sim import metrics` imports the module hpctl.sim.metrics.
                full = f"{node.module}.{a.name}"
                out.add(full if full in modules or full == "hpctl._core" else node.module)
    return out


def _graph() -> dict[str, set[str]]:
    modules = _modules()
    return {name: _imports(path, modules) - {name} for name, path in modules.items()}


def _group(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else ""


def test_every_subpackage_has_a_layer() -> None:
    groups = {_group(m) for m in _modules()} - {""}
    assert groups <= set(LAYERS), f"add {sorted(groups - set(LAYERS))} to LAYERS (and docs/architecture.md)"


def test_no_import_cycles() -> None:
    graph = _graph()
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(m: str) -> None:
        state[m] = 1
        stack.append(m)
        for n in sorted(graph.get(m, ())):
            if n not in graph:
                continue
            if state.get(n) == 1:
                cycle = stack[stack.index(n):] + [n]
                pytest.fail("import cycle: " + " -> ".join(cycle))
            if n not in state:
                visit(n)
        stack.pop()
        state[m] = 2

    for m in sorted(graph):
        if m not in state:
            visit(m)


def test_imports_run_one_way() -> None:
    wrong = []
    for module, imported in _graph().items():
        group = _group(module)
        if group == "":
            continue  # the package root re-exports the public API
        for other in imported:
            other_group = _group(other)
            if other_group == "" or other_group == group:
                continue
            if LAYERS[other_group] >= LAYERS[group]:
                wrong.append(f"{module} -> {other}")
    assert not wrong, "imports against the layering: " + ", ".join(sorted(wrong))


def test_the_graph_sees_imports() -> None:
    """The checker itself: it finds known imports (no vacuous pass)."""
    graph = _graph()
    assert "hpctl.sim.run" in graph["hpctl.identify.fit"]
    assert "hpctl.sim.metrics" in graph["hpctl.identify.dataset"]
    assert "hpctl._core" in graph["hpctl.sim.run"]
