"""The structure docs/architecture.md describes: no import circle (imports inside functions
included), no private attribute read outside its own module but by World's parts, World has
no branch on the integrator family, every stepper in the registry."""
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


# World and its own parts: the modules whose classes World holds, and which read its private
# attributes; everything else (predictions, their tape, queries, run logs, the tools) reaches
# it through its public API and World.driver
PARTS = {"world", "driver", "worldstate", "editing", "measures", "state", "forces",
         "collisions", "actors", "steppers", "coasting"}


def _private(name):
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def _defined(tree):
    """The private names a module defines: its functions and methods, and the attributes it
    assigns on self or cls."""
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)) and _private(node.name):
            names.add(node.name)
        elif isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Store) and \
                isinstance(node.value, ast.Name) and node.value.id in ("self", "cls"):
            names.add(node.attr)
    return names


def test_a_private_attribute_is_read_only_by_its_own_module_or_by_worlds_parts():
    """Every underscore attribute read on anything but self (no exemptions): it must be
    one its own module defines (a class's private on another instance of it), or, in World
    and its parts (PARTS), one they define."""
    trees = {name: ast.parse(path.read_text()) for name, path in _modules().items()}
    own = {name: _defined(tree) for name, tree in trees.items()}
    worlds = set().union(*(own[n] for n in own if n.rsplit(".", 1)[-1] in PARTS))
    offenders = []
    for name, tree in trees.items():
        allowed = own[name] | (worlds if name.rsplit(".", 1)[-1] in PARTS else set())
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and _private(node.attr) and \
                    not (isinstance(node.value, ast.Name) and node.value.id in ("self", "cls")) \
                    and node.attr not in allowed:
                offenders.append(f"{name}:{node.lineno} .{node.attr}")
    assert not offenders, offenders


def test_world_has_no_branch_on_the_integrator_family():
    source = (PACKAGE / "world.py").read_text()
    assert ".family" not in source
    assert set(sp.STEPPERS) == {spec.family for spec in sp.INTEGRATORS.values()}
    for spec in sp.INTEGRATORS.values():
        assert isinstance(sp.capabilities(spec.name), sp.Capabilities)


def test_no_public_name_is_also_a_module_of_the_package():
    """sp.NAME stays what __all__ promises whatever was imported before: importing a
    submodule spacephys.X sets the package's attribute X to that module, so a function
    named like its module (sp.lambert in lambert.py) became a module after any import of
    the module itself."""
    import importlib
    import inspect
    import pkgutil
    modules = {m.name for m in pkgutil.iter_modules(sp.__path__)}
    assert not set(sp.__all__) & modules
    for name in sorted(modules - {"__main__"}):
        importlib.import_module(f"spacephys.{name}")
    assert not [n for n in sp.__all__ if inspect.ismodule(getattr(sp, n))]


def test_the_games_use_the_public_api_only():
    """spacephys.game is written as a game developer would write it: from spacephys it
    imports the package itself and its public modules (draw, netplay, portable), nothing
    internal."""
    # (extras: the loop's one line naming the extra to install when pygame is missing)
    modules = {"spacephys.draw", "spacephys.netplay", "spacephys.portable", "spacephys.events",
               "spacephys.extras"}

    def public(m):
        return (m == "spacephys" or m in modules or m.rsplit(".", 1)[0] in modules
                or m.startswith("spacephys.game")
                or m.count(".") == 1 and m.split(".")[1] in sp.__all__)

    for path in (PACKAGE / "game").glob("*.py"):
        name = f"spacephys.game.{path.stem}".removesuffix(".__init__")
        assert not [m for m in _imports(name, path) if not public(m)], path.name


def test_portable_maths_is_public_and_the_same_functions_as_the_kernels():
    import math
    from spacephys.kernels import libm
    assert sp.portable.atan2 is libm.py.atan2
    # in index order (1e16 - 1e16) + 1 = 1; from the end 1 - 1e16 rounds to -1e16: 0
    assert sp.portable.dot([1e16, -1e16, 1.0], [1.0, 1.0, 1.0]) == 1.0
    for name in sp.portable.__all__:
        if name in ("dot", "norm"):
            continue
        fn = getattr(sp.portable, name)
        x = 0.37
        want = getattr(math, name)(x, 1.3) if name in ("atan2", "pow") else \
            (x ** (1 / 3) if name == "cbrt" else getattr(math, name)(x))
        got = fn(x, 1.3) if name in ("atan2", "pow") else fn(x)
        assert abs(got - want) <= 4 * math.ulp(want), name
    assert sp.portable.dot([1.0, 2.0, 3.0], [4.0, 5.0, 6.0]) == 32.0
    assert sp.portable.norm([3.0, 4.0]) == 5.0
