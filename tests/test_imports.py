"""What importing a module brings with it: the metrics, the report and the plots need no simulator."""

import ast
import re
import subprocess
import sys
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "morphbench"
WORLD_CLASSES = {"World", "QuasiStaticWorld", "PlanarWorld", "QuasiStatic", "Bellows", "Copy", "Copies"}
BACKEND_NAMES = {"pybullet", "quasistatic", "planar"}
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
