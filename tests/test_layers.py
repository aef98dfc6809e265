"""The library's layers point down: no import (top-level or deferred inside a function)
from a lower subpackage into a higher one, and no import circle between modules.

The imports are read from the source text (:mod:`microdoppler.codeversion`), so an
import inside a function counts like one at the top of the module.
"""

from __future__ import annotations

import collections

from microdoppler.codeversion import PACKAGE_DIR, _module_name, imported_modules

#: subpackages (and top-level modules) from the bottom up: each may import from itself
#: and from those before it only
LAYERS = (
    "errors",
    "configfields",
    "codeversion",
    "io",
    "examples",
    "spectra",
    "importing",
    "stats",
    "rotors",
    "synthesis",
    "causes",
    "emulator",
    "figures",
    "views",
    "diagnosis",
    "datasets",
    "classifier",
    "commands",
    "cli",
    "settings",
)

#: (importer, imported) pairs that still point up, each with the reason it is left
KNOWN_UPWARD: dict[tuple[str, str], str] = {}


def module_graph():
    """module -> the package's modules it imports (its own packages' __init__ aside)."""
    mods = {_module_name(f, PACKAGE_DIR): f for f in PACKAGE_DIR.rglob("*.py")}
    graph = {}
    for m, f in mods.items():
        names = imported_modules(f.read_text(), module=m, is_package=f.name == "__init__.py")
        graph[m] = {n for n in names if n in mods and n != m and not m.startswith(n + ".")}
    return graph


def layer(module: str) -> str:
    parts = module.split(".")
    return parts[1] if len(parts) > 1 else "__init__"


def test_every_subpackage_has_a_layer():
    assert {layer(m) for m in module_graph()} - {"__init__"} == set(LAYERS)


def test_imports_point_down():
    rank = {name: i for i, name in enumerate(LAYERS)}
    upward = collections.defaultdict(list)
    for m, targets in module_graph().items():
        if layer(m) == "__init__":
            continue
        for t in targets:
            if layer(t) != "__init__" and rank[layer(t)] > rank[layer(m)]:
                upward[(layer(m), layer(t))].append(f"{m} -> {t}")
    new = {k: v for k, v in upward.items() if k not in KNOWN_UPWARD}
    assert not new, f"imports that point up: {dict(new)}"
    gone = set(KNOWN_UPWARD) - set(upward)
    assert not gone, f"no longer imported upward, remove from KNOWN_UPWARD: {gone}"


def test_no_import_circle_between_modules():
    graph = module_graph()
    index, low, stack, on, circles, counter = {}, {}, [], set(), [], [0]

    def visit(v):  # Tarjan's strongly connected components
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                circles.append(sorted(comp))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    assert not circles, f"import circles: {circles}"
