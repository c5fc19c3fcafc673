"""What importing a module brings with it: the metrics, the report and the plots need no simulator."""

import ast
import re
import subprocess
import sys
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "morphbench"
WORLD_CLASSES = {"World", "QuasiStaticWorld", "PlanarWorld", "DynamicWorld", "QuasiStatic", "Bellows", "Copy", "Copies",
                 "DynamicCopies"}
BACKEND_NAMES = {"pybullet", "quasistatic", "planar", "dynamic"}
DECLARATIONS = {"params.py": "the backend choices and presets are data (PHYSICS_BACKENDS, PHYSICS_PRESETS)",
                "bench/provenance.py": "'pybullet' there is the installed distribution whose version is recorded"}


def world_names(tree: ast.AST) -> list[tuple[int, str]]:
    """Where ``tree`` names a world class, reads a world's client, tests ``client is None`` or spells a backend."""
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Name) and node.id in WORLD_CLASSES:
            found.append((node.lineno, f"names the world class {node.id}"))
        elif isinstance(node, ast.Attribute) and node.attr in WORLD_CLASSES:
            found.append((node.lineno, f"names the world class {node.attr}"))
        elif isinstance(node, ast.Attribute) and node.attr == "client" and "world" in ast.unparse(node.value)[-5:]:
            found.append((node.lineno, "reads a world's client (ask world.scene)"))
        elif isinstance(node, ast.Compare) and "client is None" in ast.unparse(node):
            found.append((node.lineno, "tests client is None (ask world.scene)"))
        elif isinstance(node, ast.Constant) and node.value in BACKEND_NAMES:
            found.append((node.lineno, f"spells the backend {node.value!r} (ask world.backend, physics.can_batch)"))
    return found


def test_metrics_report_and_plots_import_no_simulator():
    code = ("import morphbench.bench.metrics, morphbench.bench.report, morphbench.bench.figures, "
            "morphbench.bench.claims, morphbench.plots, sys; "
            "assert 'pybullet' not in sys.modules and 'numba' not in sys.modules")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)


def test_a_package_name_is_the_function_even_after_its_submodule_was_imported():
    code = ("import morphbench.experiment.run, morphbench.experiment.scan; "
            "from morphbench.experiment import run, scan; assert callable(run) and callable(scan); "
            "assert run.__module__ == 'morphbench.experiment.driver' and "
            "scan.__module__ == 'morphbench.experiment.scan'")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=120)


def test_no_code_outside_physics_names_a_world_class_or_a_backend():
    """The run loop, events, sensors, renderer and suites ask a world's declared capabilities
    (physics.protocol.WorldInterface: ``backend``, ``scene``; ``can_batch``, ``make_world(copies=n)``), so a new
    backend changes nothing outside physics/."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        relative = path.relative_to(PACKAGE).as_posix()
        if relative.startswith("physics/") or relative in DECLARATIONS:
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        found += [f"{relative}:{line}: {what}" for line, what in world_names(tree)]
    assert not found, "\n".join(found)


def test_the_check_finds_what_it_forbids():
    code = """
world = World(shape)
if isinstance(world, QuasiStaticWorld) or world.client is None or physics.backend == "quasistatic":
    pass
"""
    whats = [what for _, what in world_names(ast.parse(code))]
    assert len(whats) == 5 and any("client is None" in w for w in whats) and any("'quasistatic'" in w for w in whats)


def test_docs_architecture_names_every_module():
    """docs/architecture.md (or, for bench/, the package docstring it points to) names every module of the package,
    so a new maintainer finds each one's job there."""
    architecture = (PACKAGE.parent / "docs" / "architecture.md").read_text(encoding="utf-8")
    missing = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if path.name == "__init__.py":
            continue
        listing = architecture + ast.get_docstring(ast.parse((path.parent / "__init__.py").read_text("utf-8")) or "")
        if not re.search(rf"(^|[\s/`]){re.escape(path.name)}\b", listing, re.MULTILINE):
            missing.append(path.relative_to(PACKAGE).as_posix())
    assert not missing, f"modules docs/architecture.md does not name: {', '.join(missing)}"


FLOORS = {
    "errors": 1, "failures": 1, "streams": 1, "lazy": 1, "identity": 1, "progress": 1, "__init__": 1,
    "files": 2, "rules": 2,
    "params": 3, "readers": 3,
    "shapes": 4, "sensing": 4, "learning": 4,
    "physics": 5, "plots": 5,
    "experiment": 6,
    "render": 7, "envs": 7,
    "bench": 8,
    "cli": 9,
}
"""The rooms of the package, from the ground up: a room uses only rooms on its floor or below (docs/architecture.md
lists them in this order), so each concept lives in one room that the rooms above it use."""


def module_imports(package: Path = PACKAGE) -> dict[str, set[str]]:
    """Every module of ``package`` (dotted, from 'morphbench') and the package's modules it imports anywhere in its
    text: at the top, inside functions and under TYPE_CHECKING alike (an import deferred is still a dependency). ``from
    P import name`` counts as importing P.name when that is a module, else P itself."""
    root = package.name
    modules = {}
    for path in package.rglob("*.py"):
        parts = path.relative_to(package.parent).with_suffix("").parts
        modules[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    graph = {}
    for name, path in modules.items():
        found = set()
        for node in ast.walk(ast.parse(path.read_text("utf-8"))):
            if isinstance(node, ast.Import):
                found |= {alias.name for alias in node.names if alias.name.split(".")[0] == root}
            elif isinstance(node, ast.ImportFrom) and node.module and node.module.split(".")[0] == root:
                for alias in node.names:
                    found.add(f"{node.module}.{alias.name}" if f"{node.module}.{alias.name}" in modules
                              else node.module)
        graph[name] = {m for m in found if m in modules and m != name}
    return graph


def room(module: str) -> str:
    """The room a module sits in: its sub-package, or its own name at the top of the package."""
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected groups of more than one module (Tarjan): modules that import each other, however
    far round."""
    index, low, stack, on_stack, found = {}, {}, [], set(), []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for other in sorted(graph[node]):
            if other not in index:
                visit(other)
                low[node] = min(low[node], low[other])
            elif other in on_stack:
                low[node] = min(low[node], index[other])
        if low[node] == index[node]:
            group = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                group.append(member)
                if member == node:
                    break
            if len(group) > 1:
                found.append(sorted(group))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return found


def upward(graph: dict[str, set[str]]) -> list[str]:
    """Imports from a room into a room on a higher floor (``FLOORS``)."""
    return [f"{module} -> {other}" for module, others in sorted(graph.items()) for other in sorted(others)
            if FLOORS[room(module)] < FLOORS[room(other)]]


def test_the_import_graph_has_no_circles_and_no_import_upward():
    graph = module_imports()
    assert set(map(room, graph)) <= set(FLOORS), f"rooms without a floor: {set(map(room, graph)) - set(FLOORS)}"
    assert not circles(graph), f"modules that import each other: {circles(graph)}"
    assert not upward(graph), f"imports into a higher room: {upward(graph)}"


def test_the_graph_check_finds_circles_and_upward_imports(tmp_path):
    package = tmp_path / "morphbench"
    (package / "experiment").mkdir(parents=True)
    (package / "bench").mkdir()
    for init in (package, package / "experiment", package / "bench"):
        (init / "__init__.py").write_text("")
    (package / "experiment" / "driver.py").write_text("from morphbench.experiment.clocks import Schedule\n")
    (package / "experiment" / "clocks.py").write_text(
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from morphbench.experiment.driver import Driver\n")
    (package / "experiment" / "run.py").write_text("def f():\n    from morphbench.bench import identity\n")
    (package / "bench" / "identity.py").write_text("import morphbench.errors\n")
    graph = module_imports(package)
    assert circles(graph) == [["morphbench.experiment.clocks", "morphbench.experiment.driver"]]
    assert upward(graph) == ["morphbench.experiment.run -> morphbench.bench.identity"]
