"""TOML scenarios: the schema in code, every problem reported with its key path, and the
World and timeline they describe (docs/scenarios.md has the format); the scenarios that come
with spacephys (package data, spacephys/scenarios/NAME.toml) by name.

load_scenario(path or text) checks the whole file first and raises ScenarioError listing
every problem (`bodies[2].mass: must be >= 0 (got -1.0)`), so nothing is built or run from
a file with a mistake in it.
"""
import contextlib
import math
import os
import re
import tomllib
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

import numpy as np

from .entities import ExplosionSpec, MissileSpec, ShipSpec
from .integrators import INTEGRATORS
from .forces import MUTUAL, THETA_MAX
from .steppers import capabilities
from . import _validate as check
from .kernels import conics
from .orbits import elements_to_state
from .plans import Burn, hohmann
from .units import UNITS
from .world import BOUNDARIES, DEFAULT_KINDS, GRAVITY_MODELS, PASSIVE_KINDS, RESPONSES, World

REQUIRED = object()
# key -> (type, default); types: float, int, str, bool, vec (dim floats), strs, table, any
_WORLD = {"dim": ("int", 2), "units": ("str", "game"), "G": ("float", None),
          "integrator": ("str", "leapfrog"), "dt": ("float", REQUIRED),
          "duration": ("float", REQUIRED), "tolerance": ("float", None),
          "max_step": ("float", None), "min_step": ("float", None),
          "gravity": ("str", "direct"), "g": ("vec", None), "central_mass": ("float", None),
          "central_pos": ("vec", None), "softening": ("float", 0.0), "seed": ("int", 0),
          "kinds": ("strs", []), "center_of_mass": ("bool", False), "drag": ("float", 0.0),
          "wind": ("vec", None), "theta": ("float", None), "quadrupole": ("bool", None),
          "coast": ("str", None)}
_PLACE = {"pos": ("vec", None), "vel": ("vec", None), "parent": ("str", None),
          "a": ("float", None), "e": ("float", 0.0), "i": ("float", 0.0),
          "Omega": ("float", 0.0), "omega": ("float", 0.0), "M": ("float", None),
          "f": ("float", None)}
_BODY = {"name": ("str", REQUIRED), "mass": ("float", REQUIRED), "radius": ("float", 0.0),
         "kind": ("str", "body"), "active": ("bool", None), "fixed": ("bool", False),
         "lifetime": ("float", None), "rails": ("str", None), "spk": ("any", None), **_PLACE}
RAILS = ("kepler", "ephemeris")
_EPHEMERIS = {"file": ("str", REQUIRED), "epoch": ("float", 2451545.0)}
_RING = {"name": ("str", REQUIRED), "count": ("int", REQUIRED), "parent": ("str", REQUIRED),
         "a": ("range", REQUIRED), "e": ("range", [0.0, 0.0]), "i": ("range", [0.0, 0.0]),
         "mass": ("range", [0.0, 0.0]), "radius": ("range", [0.0, 0.0]),
         "kind": ("str", "asteroid"), "seed": ("int", 0), "total_mass": ("float", None),
         "active": ("bool", None), "Omega": ("range", None), "coast": ("bool", False)}
_SHIP = {"name": ("str", REQUIRED), "spec": ("table", REQUIRED), "heading": ("any", None),
         **_PLACE}
_COLLISION = {"a": ("str", REQUIRED), "b": ("str", REQUIRED), "response": ("str", REQUIRED),
              "restitution": ("float", None)}
_BOUNDARY = {"mode": ("str", REQUIRED), "lo": ("vec", None), "hi": ("vec", None),
             "restitution": ("float", 1.0)}
_WALL = {"a": ("vec", None), "b": ("vec", None), "point": ("vec", None),
         "normal": ("vec", None), "restitution": ("float", 1.0)}
_CONTROL = {"ship": ("str", REQUIRED), "throttle": ("float", None), "turn": ("any", None),
            "strafe": ("any", None), "heading": ("any", None), "fuel": ("float", None)}
_LAUNCH = {"from": ("str", REQUIRED), "missile": ("str", REQUIRED), "target": ("str", None),
           "heading": ("any", None), "name": ("str", None)}
_BURN = {"start": ("float", REQUIRED), "duration": ("float", REQUIRED),
         "direction": ("any", "prograde"), "frame": ("str", None), "throttle": ("float", 1.0)}
_PLAN = {"ship": ("str", REQUIRED), "burns": ("tables", REQUIRED)}
_HOHMANN = {"ship": ("str", REQUIRED), "radius": ("float", REQUIRED), "about": ("str", None)}
_ACTIONS = ("control", "launch", "spawn", "remove", "explode", "plan", "hohmann")
_EVENT = {"t": ("float", REQUIRED), "control": ("table", None), "launch": ("table", None),
          "spawn": ("table", None), "remove": ("str", None), "explode": ("str", None),
          "plan": ("table", None), "hohmann": ("table", None)}
_LOG = {"path": ("str", REQUIRED), "every": ("int", None), "every_time": ("float", None)}
_TOP = {"title": ("str", ""), "description": ("str", ""), "world": ("table", REQUIRED),
        "bodies": ("tables", []), "rings": ("tables", []), "ships": ("tables", []), "missiles": ("table", {}),
        "collisions": ("tables", []), "boundary": ("table", None), "walls": ("tables", []),
        "timeline": ("tables", []), "log": ("table", None), "ephemeris": ("table", None)}


class ScenarioError(ValueError):
    """A scenario with mistakes: .problems lists (key path, message), one per mistake."""

    def __init__(self, source, problems):
        self.problems = problems
        lines = [f"{source}: {len(problems)} problem{'s' if len(problems) > 1 else ''}"]
        lines += [f"  {path}: {message}" for path, message in problems]
        super().__init__("\n".join(lines))


@dataclass
class Scenario:
    """A checked scenario: the World it builds (build()) and what happens when."""
    source: str
    text: str
    data: dict
    title: str = ""
    duration: float = 0.0
    timeline: list = field(default_factory=list)      # (t, action, table, key path) sorted by t
    log: dict = None

    def build(self, **world):
        """A new World at t = 0 with the scenario's bodies, ships and rules; and name -> id.
        world: settings of [world] to override (integrator=, dt=), the Scenario unchanged."""
        return _build({**self.data, "world": {**self.data["world"], **world}}, self.source)


class _Checker:
    def __init__(self, dim):
        self.dim = dim
        self.problems = []

    def bad(self, path, message):
        self.problems.append((path, message))

    def has(self, path):
        return any(p == path for p, _ in self.problems)

    def table(self, path, value, schema):
        """value checked against schema: a dict with every key (defaults filled in), or
        None if it is not a table at all."""
        if not isinstance(value, dict):
            self.bad(path, f"must be a table, got {type(value).__name__}")
            return None
        out = {}
        for key in value:
            if key not in schema:
                self.bad(f"{path}.{key}" if path else key,
                         f"unknown key; valid: {', '.join(schema)}")
        for key, (kind, default) in schema.items():
            where = f"{path}.{key}" if path else key
            if key not in value:
                if default is REQUIRED:
                    self.bad(where, "missing")
                out[key] = None if default is REQUIRED else default
                continue
            out[key] = self.value(where, value[key], kind)
        return out

    def value(self, path, v, kind):
        ok = {"float": lambda: isinstance(v, (int, float)) and not isinstance(v, bool),
              "int": lambda: isinstance(v, int) and not isinstance(v, bool),
              "str": lambda: isinstance(v, str), "bool": lambda: isinstance(v, bool),
              "strs": lambda: isinstance(v, list) and all(isinstance(x, str) for x in v),
              "table": lambda: isinstance(v, dict),
              "tables": lambda: isinstance(v, list) and all(isinstance(x, dict) for x in v),
              "vec": lambda: isinstance(v, list) and len(v) == self.dim and all(
                  isinstance(x, (int, float)) and not isinstance(x, bool) for x in v),
              "range": lambda: isinstance(v, list) and len(v) == 2 and all(
                  isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)
              and v[0] <= v[1],
              "any": lambda: True}[kind]()
        if not ok:
            want = {"float": "a number", "int": "an integer", "str": "text",
                    "bool": "true or false", "strs": "a list of text", "table": "a table",
                    "tables": "an array of tables", "vec": f"{self.dim} numbers",
                    "range": "[low, high] with low <= high"}[kind]
            self.bad(path, f"must be {want}, got {v!r}")
            return None
        if kind == "float" and not math.isfinite(v):
            self.bad(path, f"must be finite, got {v!r}")
            return None
        return float(v) if kind == "float" else v

    def minimum(self, path, v, low, strict=False):
        if v is not None and (v <= low if strict else v < low):
            self.bad(path, f"must be {'>' if strict else '>='} {low:g} (got {v!r})")


def _parse(source, text):
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ScenarioError(source, [("(file)", f"not valid TOML: {e}")]) from None


def shipped():
    """{name: path} of the scenarios that come with spacephys, sorted by name (package data:
    found wherever spacephys is installed)."""
    folder = resources.files(__package__) / "scenarios"
    return {p.name[:-5]: Path(os.fspath(p))
            for p in sorted(folder.iterdir(), key=lambda p: p.name) if p.name.endswith(".toml")}


def summary_line(path):
    """The first sentence of a scenario file's description (its title if it has none)."""
    with open(path, "rb") as f:
        top = tomllib.load(f)
    text = top.get("description") or top.get("title") or ""
    depth = 0
    for k, c in enumerate(text):
        depth += (c == "(") - (c == ")")
        if depth == 0 and c in ".:;" and text[k + 1:k + 2] in ("", " "):
            return text[:k]
    return text


def _is_name(text):
    """A bare word such as "two_body": the name of a shipped scenario, not a path or TOML."""
    return isinstance(text, str) and re.fullmatch(r"[A-Za-z0-9_\-]+", text) is not None


def load_scenario(path_or_text, overrides=None):
    """Read and check a scenario (a path to a .toml file, the name of a shipped one such as
    "two_body" (shipped()), or its text); ScenarioError lists every problem. overrides:
    {key path: value} set in the file's tables before the checks (see set_key: "world.dt",
    "ships.red.vel", "bodies[0].mass"), as if the file said so."""
    text = path_or_text
    if _is_name(text):
        known = shipped()
        if text not in known:
            raise ScenarioError(text, [("(name)", "no shipped scenario has this name; they "
                                                  "are: " + ", ".join(known))])
        text = path_or_text = known[text]
    if isinstance(text, os.PathLike) or isinstance(text, str) and "\n" not in text \
            and text.endswith(".toml"):
        source = os.fspath(path_or_text)
        try:
            with open(source, encoding="utf-8") as f:
                text = f.read()
        except OSError as e:
            raise ScenarioError(source, [("(file)", f"cannot be read: {e.strerror}")]) from None
    else:
        source, text = "<scenario>", str(path_or_text)
    data = _parse(source, text)
    for key, value in (overrides or {}).items():
        set_key(source, data, key, value)
    dim = data.get("world", {}).get("dim", 2) if isinstance(data.get("world"), dict) else 2
    chk = _Checker(dim if dim in (2, 3) else 2)
    top = chk.table("", data, _TOP)
    if top is None or top["world"] is None:
        raise ScenarioError(source, chk.problems or [("world", "missing")])
    world = chk.table("world", top["world"], _WORLD)
    if world:
        _check_world(chk, world)
    names = {}
    for key, schema in (("bodies", _BODY), ("ships", _SHIP)):
        for k, item in enumerate(top[key] or []):
            path = f"{key}[{k}]"
            t = chk.table(path, item, schema)
            if t is None:
                continue
            if key == "bodies" and t["rails"] == "ephemeris":
                _check_ephemeris_body(chk, path, t, names, top, world)
            else:
                _check_place(chk, path, t, names, key)
            if key == "bodies":
                _check_rails(chk, path, t, world)
                chk.minimum(f"{path}.mass", t["mass"], 0.0)
                chk.minimum(f"{path}.radius", t["radius"], 0.0)
                chk.minimum(f"{path}.lifetime", t["lifetime"], 0.0, strict=True)
            elif t["spec"] is not None:
                _spec(chk, f"{path}.spec", ShipSpec, t["spec"])
            top[key][k] = t
    for k, item in enumerate(top["rings"] or []):
        path = f"rings[{k}]"
        t = chk.table(path, item, _RING)
        if t is None:
            continue
        if t["parent"] is not None and t["parent"] not in names:
            chk.bad(f"{path}.parent", f"{t['parent']!r} names no body defined before it")
        chk.minimum(f"{path}.count", t["count"], 1)
        chk.minimum(f"{path}.seed", t["seed"], 0)
        for key in ("a", "mass", "radius"):
            low = None if t[key] is None else t[key][0]
            if key == "a" and low is not None and low <= 0:
                chk.bad(f"{path}.a", f"must be > 0 (got {t['a']!r})")
            elif low is not None and low < 0:
                chk.bad(f"{path}.{key}", f"must be >= 0 (got {t[key]!r})")
        if t["e"] is not None and not (0.0 <= t["e"][0] and t["e"][1] < 1.0):
            chk.bad(f"{path}.e", f"must lie in [0, 1) (got {t['e']!r})")
        if chk.dim == 2 and t["i"] and any(t["i"]):
            chk.bad(f"{path}.i", "a 2D ring lies in the plane: i must be [0, 0]")
        if t["total_mass"] is not None:
            chk.minimum(f"{path}.total_mass", t["total_mass"], 0.0)
            if "mass" in item:
                chk.bad(f"{path}.total_mass", "give either mass (a range per body) or "
                                              "total_mass (shared equally), not both")
        top["rings"][k] = t
    missiles = {}
    for name, spec in (top["missiles"] or {}).items():
        if not isinstance(spec, dict):
            chk.bad(f"missiles.{name}", "must be a table of MissileSpec fields")
            continue
        missiles[name] = _spec(chk, f"missiles.{name}", MissileSpec, spec)
    for k, item in enumerate(top["collisions"] or []):
        t = chk.table(f"collisions[{k}]", item, _COLLISION)
        if t and t["response"] is not None and t["response"] not in RESPONSES:
            chk.bad(f"collisions[{k}].response", f"{t['response']!r} is not a response; "
                                                  f"valid: {', '.join(RESPONSES)}")
        if t:
            top["collisions"][k] = t
    if top["boundary"] is not None:
        t = chk.table("boundary", top["boundary"], _BOUNDARY)
        if t and t["mode"] is not None and t["mode"] not in BOUNDARIES:
            chk.bad("boundary.mode", f"{t['mode']!r} is not a boundary; valid: "
                                     f"{', '.join(BOUNDARIES)}")
        top["boundary"] = t
    for k, item in enumerate(top["walls"] or []):
        t = chk.table(f"walls[{k}]", item, _WALL)
        if t and (t["a"] is None) == (t["point"] is None):
            chk.bad(f"walls[{k}]", "give a segment (a, b) or a plane (point, normal)")
        top["walls"][k] = t
    timeline = _check_timeline(chk, top["timeline"] or [], names, missiles)
    _check_kinds(chk, top, world, missiles)
    if top["log"] is not None:
        top["log"] = chk.table("log", top["log"], _LOG)
    if top["ephemeris"] is not None:
        top["ephemeris"] = chk.table("ephemeris", top["ephemeris"], _EPHEMERIS)
    if chk.problems:
        raise ScenarioError(source, chk.problems)
    top["missiles"] = missiles
    top["world"] = world
    return Scenario(source, text, top, top["title"], world["duration"], timeline, top["log"])


_KEY_PART = re.compile(r"([^.\[\]]+)|\[(-?\d+)\]")


def key_parts(key):
    """A key path's steps: "bodies[2].mass" -> ["bodies", 2, "mass"]; ValueError if it is
    not one."""
    parts, at = [], 0
    while isinstance(key, str) and at < len(key):
        m = _KEY_PART.match(key, at)
        if m is None:
            break
        parts.append(m.group(1) if m.group(1) is not None else int(m.group(2)))
        at = m.end()
        if at < len(key) and key[at] != "[":        # then a [index], or a dot and a name
            if key[at] != "." or at + 1 == len(key) or key[at + 1] in ".[":
                break
            at += 1
    if not parts or not isinstance(key, str) or at != len(key) or isinstance(parts[0], int):
        raise ValueError(f"key path {key!r}: expected names and [index]es joined by dots, "
                         f"as world.dt, ships.red.vel or bodies[0].mass")
    return parts


def set_key(source, data, key, value):
    """Set the value at a key path in a scenario's parsed tables: tables by key, arrays of
    tables by [index] or by the name of their entry (ships.red is the ship named "red"). A
    path that leads nowhere is refused (ScenarioError naming it); the value itself is
    checked with the rest of the file."""
    try:
        parts = key_parts(key)
    except ValueError as e:
        raise ScenarioError(source, [(str(key), str(e))]) from None
    node = data
    for k, part in enumerate(parts):
        here = key if k == len(parts) - 1 else _join(parts[:k + 1])
        if isinstance(node, list):
            names = [t.get("name") if isinstance(t, dict) else None for t in node]
            if isinstance(part, int):
                if not 0 <= part < len(node):
                    raise ScenarioError(source, [(key, f"{_join(parts[:k])} has "
                                                      f"{len(node)} entries, no [{part}]")])
                at = part
            elif part in names:
                at = names.index(part)
            else:
                named = ", ".join(str(n) for n in names if n is not None) or "none"
                raise ScenarioError(source, [(key, f"{_join(parts[:k])} has no entry named "
                                                  f"{part!r} (named: {named})")])
        elif isinstance(node, dict) and not isinstance(part, int):
            if part not in node and k < len(parts) - 1:
                raise ScenarioError(source, [(key, f"the scenario has no {here}")])
            at = part
        else:
            raise ScenarioError(source, [(key, f"{_join(parts[:k])} is "
                                              f"{'a table' if isinstance(node, dict) else 'a value'}"
                                              f", not {'an array' if isinstance(part, int) else 'a table'}")])
        if k == len(parts) - 1:
            node[at] = value
        else:
            node = node[at]


def _join(parts):
    return "".join(f"[{p}]" if isinstance(p, int) else (f".{p}" if i else p)
                   for i, p in enumerate(parts))


def _check_kinds(chk, top, world, missiles):
    """Kinds named by bodies and collision rules must be declared (world.kinds) or be
    those of the built-in set or of a ship, missile or explosion spec: a typo in a rule would
    otherwise silently match nothing."""
    known = set(DEFAULT_KINDS) | set((world or {}).get("kinds") or [])
    for t in top["ships"] or []:
        if isinstance(t, dict) and isinstance(t.get("spec"), dict):
            known.add(t["spec"].get("kind", "ship"))
    for spec in missiles.values():
        if spec is not None:
            known.add(spec.kind)
            if spec.explosion is not None:
                known.add(spec.explosion.kind)
    for k, t in enumerate(top["rings"] or []):
        if isinstance(t, dict) and isinstance(t.get("kind"), str) and t["kind"] not in known:
            chk.bad(f"rings[{k}].kind", f"{t['kind']!r} is not declared; add it to "
                                        f"world.kinds")
    for k, t in enumerate(top["bodies"] or []):
        if isinstance(t, dict) and isinstance(t.get("kind"), str) and t["kind"] not in known:
            chk.bad(f"bodies[{k}].kind", f"{t['kind']!r} is not declared; add it to "
                                         f"world.kinds (known: {', '.join(sorted(known))})")
    for k, t in enumerate(top["collisions"] or []):
        for side in ("a", "b"):
            v = t.get(side) if isinstance(t, dict) else None
            if isinstance(v, str) and v != "*" and v not in known:
                chk.bad(f"collisions[{k}].{side}", f"{v!r} is not a declared kind (known: "
                                                   f"{', '.join(sorted(known))})")


def _check_world(chk, w):
    if w["dim"] not in (2, 3):
        chk.bad("world.dim", f"must be 2 or 3 (got {w['dim']!r})")
    for key, valid in (("units", UNITS), ("integrator", INTEGRATORS),
                       ("gravity", GRAVITY_MODELS)):
        if w[key] is not None and w[key] not in valid:
            chk.bad(f"world.{key}", f"{w[key]!r} is not known; valid: {', '.join(valid)}")
    chk.minimum("world.dt", w["dt"], 0.0, strict=True)
    chk.minimum("world.duration", w["duration"], 0.0, strict=True)
    chk.minimum("world.G", w["G"], 0.0)
    chk.minimum("world.softening", w["softening"], 0.0)
    chk.minimum("world.drag", w["drag"], 0.0)
    if w["integrator"] in INTEGRATORS and w["gravity"] in GRAVITY_MODELS and \
            w["gravity"] not in capabilities(w["integrator"]).models:
        chk.bad("world.integrator", f"{w['integrator']!r} needs gravity in "
                                    f"{capabilities(w['integrator']).models} (gravity = "
                                    f"{w['gravity']!r})")
    chk.minimum("world.seed", w["seed"], 0)
    if w["gravity"] == "uniform" and w["g"] is None:
        chk.bad("world.g", "missing: gravity = 'uniform' needs the field vector g")
    if w["gravity"] == "central" and w["central_mass"] is None:
        chk.bad("world.central_mass", "missing: gravity = 'central' needs it")
    if w["coast"] not in (None, "auto"):
        chk.bad("world.coast", f"{w['coast']!r} is not known; valid: 'auto'")
    for key in ("theta", "quadrupole"):
        if w[key] is not None and w["gravity"] != "tree":
            chk.bad(f"world.{key}", f"only used with gravity = 'tree' (gravity = "
                                    f"{w['gravity']!r})")
    if w["theta"] is not None and not 0.0 < w["theta"] <= THETA_MAX:
        chk.bad("world.theta", f"must lie in (0, {THETA_MAX}] (got {w['theta']!r})")


def _check_rails(chk, path, t, world):
    rails = t["rails"]
    if rails is None:
        return
    if rails not in RAILS:
        chk.bad(f"{path}.rails", f"{rails!r} is not a kind of rails; valid: {', '.join(RAILS)}")
    elif rails == "kepler" and t["parent"] is None:
        chk.bad(f"{path}.rails", "'kepler' rails are an orbit about a parent: give parent")
    if world and str(world["integrator"]).startswith("wisdom_holman"):
        chk.bad(f"{path}.rails", f"integrator {world['integrator']!r} takes no bodies on rails")


def _check_ephemeris_body(chk, path, t, names, top, world):
    """A body on the scenario's ephemeris: its place comes from it (no pos, no parent)."""
    _register(chk, path, t, names)
    if top["ephemeris"] is None:
        chk.bad(f"{path}.rails", "'ephemeris' rails need the scenario's [ephemeris] table")
    if t["spk"] is None:
        chk.bad(f"{path}.spk", "missing: the body's name or NAIF id in the ephemeris")
    for k in ("pos", "vel", "parent", "a"):
        if t[k] is not None:
            chk.bad(f"{path}.{k}", "a body on the ephemeris takes its place from it")
    if world and world["center_of_mass"]:
        chk.bad("world.center_of_mass", "the ephemeris sets its bodies' frame (the Solar "
                                         "System barycentre): no centre-of-mass shift")
    if world and world["units"] not in ("si", "au-msun-yr"):       # ephemeris.SCALE's
        chk.bad("world.units", f"{world['units']!r}: an ephemeris needs units with a length "
                               f"and a time ('si' or 'au-msun-yr')")


def _register(chk, path, t, names):
    """Note the table's name (refused when used twice)."""
    name = t["name"]
    if name is not None:
        if name in names:
            chk.bad(f"{path}.name", f"{name!r} is used twice (also {names[name]})")
        names[name] = path


def _check_place(chk, path, t, names, key):
    _register(chk, path, t, names)
    if t["parent"] is None:
        if t["pos"] is None and not chk.has(f"{path}.pos"):
            chk.bad(f"{path}.pos", "missing (or give parent and orbital elements)")
        for k in ("a", "M", "f"):
            if t[k] is not None:
                chk.bad(f"{path}.{k}", "orbital elements need a parent")
        return
    if t["parent"] not in names or names[t["parent"]] == path:
        chk.bad(f"{path}.parent", f"{t['parent']!r} names no body defined before it")
    for k in ("pos", "vel"):
        if t[k] is not None:
            chk.bad(f"{path}.{k}", "give either pos/vel or parent and orbital elements")
    if t["a"] is None:
        chk.bad(f"{path}.a", "missing: the semi-major axis of the orbit about the parent")
    else:
        chk.minimum(f"{path}.a", t["a"], 0.0, strict=True)
    if t["e"] is not None and not 0.0 <= t["e"] < 1.0:
        chk.bad(f"{path}.e", f"must be in [0, 1) for an orbit with a > 0 (got {t['e']!r})")
    if t["M"] is not None and t["f"] is not None:
        chk.bad(f"{path}.f", "give M (mean anomaly) or f (true anomaly), not both")
    if chk.dim == 2 and (t["i"] or t["Omega"]):
        chk.bad(f"{path}.i", "a 2D orbit lies in the plane: i and Omega must be 0")


def _spec(chk, path, cls, table):
    fields = dict(table)
    if "explosion" in fields:
        if not isinstance(fields["explosion"], dict):
            chk.bad(f"{path}.explosion", "must be a table of ExplosionSpec fields")
            return None
        fields["explosion"] = _spec(chk, f"{path}.explosion", ExplosionSpec,
                                    fields["explosion"])
        if fields["explosion"] is None:
            return None
    try:
        return cls(**fields)
    except TypeError as e:              # an unknown field
        chk.bad(path, f"{e}".replace("__init__() ", "").replace(cls.__name__ + ".", ""))
    except ValueError as e:
        chk.bad(path, str(e))
    return None


def _check_timeline(chk, entries, names, missiles):
    out = []
    for k, item in enumerate(entries):
        path = f"timeline[{k}]"
        t = chk.table(path, item, _EVENT)
        if t is None:
            continue
        actions = [a for a in _ACTIONS if t[a] is not None]
        if len(actions) != 1:
            chk.bad(path, f"give exactly one of {', '.join(_ACTIONS)}")
            continue
        chk.minimum(f"{path}.t", t["t"], 0.0)
        action = actions[0]
        value = t[action]
        if action == "control":
            value = chk.table(f"{path}.control", value, _CONTROL)
            if value and value["ship"] not in names:
                chk.bad(f"{path}.control.ship", f"{value['ship']!r} names no ship")
        elif action == "launch":
            value = chk.table(f"{path}.launch", value, _LAUNCH)
            if value:
                if value["from"] not in names:
                    chk.bad(f"{path}.launch.from", f"{value['from']!r} names no body")
                if value["missile"] not in missiles:
                    chk.bad(f"{path}.launch.missile", f"{value['missile']!r} is not in "
                                                      f"[missiles]")
                if value["target"] is not None and value["target"] not in names:
                    chk.bad(f"{path}.launch.target", f"{value['target']!r} names no body")
                if value["name"] is not None:
                    names[value["name"]] = f"{path}.launch"
        elif action == "plan":
            value = _check_plan(chk, f"{path}.plan", value, names)
        elif action == "hohmann":
            value = chk.table(f"{path}.hohmann", value, _HOHMANN)
            if value:
                _check_names(chk, f"{path}.hohmann", value, ("ship", "about"), names)
                chk.minimum(f"{path}.hohmann.radius", value["radius"], 0.0, strict=True)
        elif action == "spawn":
            value = chk.table(f"{path}.spawn", value, _BODY)
            if value:
                _check_place(chk, f"{path}.spawn", value, names, "bodies")
                chk.minimum(f"{path}.spawn.mass", value["mass"], 0.0)
        elif value not in names:
            chk.bad(f"{path}.{action}", f"{value!r} names no body")
        if t["t"] is not None:           # a bad t is a problem already: nothing to sort by
            out.append((t["t"], action, value, path))
    out.sort(key=lambda e: e[0])          # stable: same-time entries keep their order
    return out


def _check_names(chk, path, value, keys, names):
    for key in keys:
        if value[key] is not None and value[key] not in names:
            chk.bad(f"{path}.{key}", f"{value[key]!r} names no body")


def _check_plan(chk, path, value, names):
    """A plan's ship and burns (each as sp.Burn checks it; the World checks the rest when the
    plan is set: order, start times, a ship)."""
    value = chk.table(path, value, _PLAN)
    if not value:
        return value
    _check_names(chk, path, value, ("ship",), names)
    burns = []
    for j, b in enumerate(value["burns"] or []):
        b = chk.table(f"{path}.burns[{j}]", b, _BURN)
        if not b:
            continue
        _check_names(chk, f"{path}.burns[{j}]", b, ("frame",), names)
        try:
            Burn(b["start"], b["duration"], b["direction"], None, b["throttle"])
        except ValueError as e:
            chk.bad(f"{path}.burns[{j}]", str(e))
        burns.append(b)
    value["burns"] = burns
    return value


# ----------------------------------------------------------------------------- building

def _place(w, t, ids):
    """pos, vel (dim,) of a body table: given, or from elements about its parent."""
    dim = w.dim
    if t["parent"] is None:
        vel = t["vel"] if t["vel"] is not None else [0.0] * dim
        return np.array(t["pos"], float), np.array(vel, float)
    parent = w.get(ids[t["parent"]])
    # mu = G (M + m) for a body that pulls back; a passive one (a ship) orbits in M's field
    mass = (t.get("mass") or 0.0) if t.get("pulls", True) else 0.0
    deg = math.radians
    kw = {"f": deg(t["f"])} if t["f"] is not None else {"M": deg(t["M"] or 0.0)}
    pos, vel = elements_to_state(w.G * (parent.mass + mass), t["a"], t["e"], deg(t["i"]),
                                 deg(t["Omega"]), deg(t["omega"]), **kw)
    return parent.pos + pos[:dim], parent.vel + vel[:dim]


def _ephemeris(data, source):
    """The scenario's ephemeris (sp.Ephemeris.from_spk) for its bodies on it, over its
    duration, its time 0 at the epoch; None without one."""
    e = data.get("ephemeris")
    if e is None:
        return None
    from .ephemeris import DAY, SCALE, Ephemeris, de421_path
    world = data["world"]
    bodies = [t["spk"] for t in data["bodies"] if t["rails"] == "ephemeris"]
    days = world["duration"] * SCALE[world["units"]][1] / DAY
    with _at(source, "ephemeris"):
        path = de421_path() if e["file"] == "de421" else e["file"]
        return Ephemeris.from_spk(path, bodies, units=world["units"], start=e["epoch"] - 1.0,
                                  end=e["epoch"] + days + 2.0, epoch=e["epoch"])


def _add_body(w, t, ids, eph=None):
    if t["rails"] == "ephemeris":
        code = eph.naif(t["spk"])
        pos, vel = eph.state(code, w.t)
        ids[t["name"]] = w.add_body(t["mass"], pos, vel, radius=t["radius"], kind=t["kind"])
        w.set_rails(ids[t["name"]], ephemeris=eph, entry=code)
        return
    pulls = t["active"] if t["active"] is not None else t["kind"] not in PASSIVE_KINDS
    pos, vel = _place(w, {**t, "pulls": pulls}, ids)
    kw = {"radius": t["radius"], "kind": t["kind"], "fixed": t["fixed"]}
    if t["active"] is not None:
        kw["active"] = t["active"]
    if t["lifetime"] is not None:
        kw["lifetime"] = t["lifetime"]
    ids[t["name"]] = w.add_body(t["mass"], pos, vel, **kw)


def _add_ring(w, t, ids):
    """`count` bodies on orbits about the parent with elements drawn uniformly from the
    ranges (mean anomaly, node and pericentre uniform in angle), from an RNG seeded by the
    ring's seed: the same ring every run. total_mass: shared equally instead of the mass
    range. A ring whose bodies pull (active, or of a kind that pulls, with mass) orbits the
    parent and the ring's mass inside each orbit (a self-gravitating disc, to first order)."""
    rng = np.random.default_rng(t["seed"])
    k = t["count"]
    parent = w.get(ids[t["parent"]])
    draw = lambda key: rng.uniform(*t[key], k)
    a, e, inc, mass, radius = draw("a"), draw("e"), np.radians(draw("i")), draw("mass"), \
        draw("radius")
    if t["total_mass"] is not None:
        mass = np.full(k, t["total_mass"] / k)
    node, peri, M = (rng.uniform(0, 2 * np.pi, k) for _ in range(3))
    if t["Omega"] is not None:          # [x, x]: a disc, every orbit in one plane
        node = np.radians(draw("Omega"))
    if w.dim == 2:
        node[:] = 0.0
    pulls = t["active"] if t["active"] is not None else t["kind"] not in PASSIVE_KINDS
    inside = np.zeros(k)
    if pulls and w.gravity in MUTUAL:
        by_a = np.argsort(a, kind="stable")
        inside[by_a] = np.cumsum(mass[by_a]) - mass[by_a]
    # elements_to_state of each body, compiled (the same bits; a, e, i checked above)
    mu = check.floats("mu", w.G * (parent.mass + inside + mass), (k,), positive=True)
    pos, vel = np.empty((k, 3)), np.empty((k, 3))
    conics.elliptic_states(mu, a, e, inc, node, peri, M, pos, vel)
    kw = {} if t["active"] is None else {"active": t["active"]}
    return w.add_bodies(mass, parent.pos + pos[:, :w.dim], parent.vel + vel[:, :w.dim],
                        radius=radius, kind=t["kind"], **kw)


def _heading(value):
    """A heading of a scenario: an angle in degrees (2D) or a direction vector (3D)."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return math.radians(value)
    return value


@contextlib.contextmanager
def _at(source, path):
    """A refusal while building names the table it came from (the checks above catch most
    mistakes; the World's own checks catch the rest)."""
    try:
        yield
    except ScenarioError:
        raise
    except ValueError as e:
        raise ScenarioError(source, [(path, str(e))]) from None


def _build(data, source="<scenario>"):
    s = data["world"]
    kw = {k: s[k] for k in ("dim", "units", "integrator", "dt", "softening", "gravity", "seed",
                            "drag")}
    for k in ("G", "tolerance", "max_step", "min_step", "g", "central_mass", "central_pos",
              "wind", "theta", "quadrupole", "coast"):
        if s[k] is not None:
            kw[k] = s[k]
    with _at(source, "world"):
        w = World(**kw)
        for kind in s["kinds"]:
            w.add_kind(kind)
    ids = {}
    eph = _ephemeris(data, source)
    for k, t in enumerate(data["bodies"]):
        with _at(source, f"bodies[{k}]"):
            _add_body(w, t, ids, eph)
    rings = []
    for k, ring in enumerate(data["rings"]):
        with _at(source, f"rings[{k}]"):
            rings.append(_add_ring(w, ring, ids))
    for k, t in enumerate(data["ships"]):
        with _at(source, f"ships[{k}].spec"):
            spec = ShipSpec(**{key: (ExplosionSpec(**v) if key == "explosion" else v)
                               for key, v in t["spec"].items()})
        with _at(source, f"ships[{k}]"):
            pos, vel = _place(w, {**t, "mass": spec.dry_mass + spec.fuel_mass,
                                  "pulls": spec.active}, ids)
            ids[t["name"]] = w.add_ship(spec, pos, vel, heading=_heading(t["heading"]))
    if s["center_of_mass"]:
        w.move_to_center_of_mass()
    for k, t in enumerate(data["bodies"]):
        if t["rails"] == "kepler":                 # after the shift: an orbit is relative
            with _at(source, f"bodies[{k}].rails"):
                w.set_rails(ids[t["name"]], ids[t["parent"]])
    for k, ring in enumerate(data["rings"]):
        if ring["coast"]:                           # after the rails: the spheres are known
            with _at(source, f"rings[{k}].coast"):
                w.coast(rings[k])
    for k, c in enumerate(data["collisions"]):
        with _at(source, f"collisions[{k}]"):
            w.set_collision(c["a"], c["b"], c["response"], restitution=c["restitution"])
    b = data["boundary"]
    if b is not None:
        with _at(source, "boundary"):
            w.set_boundary(b["mode"], lo=b["lo"], hi=b["hi"], restitution=b["restitution"])
    for k, wall in enumerate(data["walls"]):
        with _at(source, f"walls[{k}]"):
            if wall["a"] is not None:
                w.add_segment(wall["a"], wall["b"], restitution=wall["restitution"])
            else:
                w.add_plane(wall["point"], wall["normal"], restitution=wall["restitution"])
    return w, ids


def apply(w, ids, missiles, action, value, path="timeline", source="<scenario>"):
    """Carry out one timeline entry on World w (ids: name -> id, grown by spawns and named
    launches); a refusal names the entry's path."""
    with _at(source, path):
        _apply(w, ids, missiles, action, value)


def _apply(w, ids, missiles, action, value):
    if action == "control":
        ship = ids[value["ship"]]
        if value["heading"] is not None:          # point the ship, then set the controls
            w.set_heading(ship, _heading(value["heading"]))
        if value["fuel"] is not None:             # refuel (or drain) first
            w.set_fuel(ship, value["fuel"])
        w.control(ship, **{k: value[k] for k in ("throttle", "turn", "strafe")
                           if value[k] is not None})
    elif action == "launch":
        target = ids[value["target"]] if value["target"] is not None else None
        body = w.launch(ids[value["from"]], missiles[value["missile"]], target=target,
                        heading=_heading(value["heading"]))
        if value["name"] is not None:
            ids[value["name"]] = body
    elif action == "plan":
        w.plan(ids[value["ship"]], [
            Burn(b["start"], b["duration"], b["direction"],
                 None if b["frame"] is None else ids[b["frame"]], b["throttle"])
            for b in value["burns"]])
    elif action == "hohmann":
        ship = ids[value["ship"]]
        about = None if value["about"] is None else ids[value["about"]]
        w.plan(ship, hohmann(w, ship, value["radius"], about))
    elif action == "spawn":
        _add_body(w, value, ids)
    elif action == "remove":
        w.remove(ids[value])
    else:
        w.explode(ids[value])
