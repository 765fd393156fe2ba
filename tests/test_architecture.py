"""The structure docs/architecture.md describes: no import circle (imports inside functions
included), nothing outside World reads its private attributes, World has no branch on the
integrator family, every stepper in the registry."""
import ast
from pathlib import Path

import spacephys as sp

PACKAGE = Path(sp.__file__).parent


def _modules():
    return {".".join(("spacephys",) + p.relative_to(PACKAGE).with_suffix("").parts)
            .removesuffix(".__init__"): p for p in PACKAGE.rglob("*.py")}


def _imports(name, path):
    """The spacephys modules `name` imports anywhere in its source."""
    package = name if path.name == "__init__.py" else name.rsplit(".", 1)[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[:len(base) - node.level + 1]
                module = ".".join(base + ([node.module] if node.module else []))
            else:
                module = node.module or ""
            targets = [module] + [f"{module}.{a.name}" for a in node.names]
        elif isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        else:
            continue
        found.update(t for t in targets if t.startswith("spacephys"))
    return found


def test_no_module_imports_itself_back():
    modules = _modules()
    graph = {name: {t for t in _imports(name, path) if t in modules and t != name}
             for name, path in modules.items()}
    # the package's __init__ re-exports everything; a module importing "spacephys" for a
    # name is an edge to that name's module, which the lazy table and __init__ resolve
    graph["spacephys"] = set()
    cycles = []

    def visit(node, trail):
        for nxt in graph[node]:
            if nxt in trail:
                cycles.append(trail[trail.index(nxt):] + [nxt])
            elif nxt not in done:
                visit(nxt, trail + [nxt])
        done.add(node)

    done = set()
    for name in graph:
        if name not in done:
            visit(name, [name])
    assert not cycles, cycles[:3]


def test_nothing_outside_world_reads_its_private_attributes():
    """World's parts (forces, collisions, actors, steppers, predict, tape, queries) are its
    own; every other module uses its public API."""
    parts = {"world", "forces", "collisions", "actors", "steppers", "predict", "tape",
             "queries"}
    private = {"_b", "_log", "_plan", "_forces", "_collisions", "_actors", "_stepper",
               "_events", "_event_count", "_steps", "_t_base", "_dt", "_watch", "_threads",
               "_origin", "_spec", "_kinds", "_accumulator"}
    offenders = []
    for name, path in _modules().items():
        if name.rsplit(".", 1)[-1] in parts:
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Attribute) and node.attr in private and not (
                    isinstance(node.value, ast.Name) and node.value.id == "self"):
                offenders.append(f"{name}:{node.lineno} .{node.attr}")
    assert not offenders, offenders


def test_world_has_no_branch_on_the_integrator_family():
    source = (PACKAGE / "world.py").read_text()
    assert ".family" not in source
    assert set(sp.STEPPERS) == {spec.family for spec in sp.INTEGRATORS.values()}
    for spec in sp.INTEGRATORS.values():
        assert isinstance(sp.capabilities(spec.name), sp.Capabilities)
