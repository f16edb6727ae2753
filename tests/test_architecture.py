"""Issue 22: the rooms of the library and the rules between them (docs/ARCHITECTURE.md): no
module over 600 lines, no import circle (function-level imports count), imports only downwards,
and a command table that loads nothing beyond the standard library."""
import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PKG = ROOT / "lidartrees_gis"

#: the rooms, lowest first; a module may import its own room and the rooms listed for it
ROOMS = {
    "core": (),  # errors, bounds, progress, crs, grid, tin, _accel, _raster
    "io": ("core",),
    "catalog": ("core", "io"),
    "report": ("core", "io"),
    "ground": ("core", "io", "catalog", "report"),
    "tls": ("core", "io", "report"),
    "plantation": ("core", "io", "report"),
    "als": ("core", "io", "catalog", "report", "ground", "plantation"),
    "synthetic": ("core", "io"),
    "inventory": ("core", "io", "catalog", "report", "ground", "plantation", "als"),
    # the adapters on top: the command line, the Python API, the demo and the fuzzer
    "top": ("core", "io", "catalog", "report", "ground", "tls", "plantation", "als",
            "synthetic", "inventory"),
}
CORE = {"errors", "bounds", "progress", "crs", "grid", "tin", "_accel", "_raster", "_version"}


def _modules():
    for f in sorted(PKG.rglob("*.py")):
        parts = f.relative_to(PKG).with_suffix("").parts
        yield f, ".".join(("lidartrees_gis",) + parts).removesuffix(".__init__")


def _room(module: str) -> str:
    parts = module.split(".")[1:]
    if not parts:
        return "top"  # the package itself: the Python API's facade
    if parts[0] in CORE:
        return "core"
    if parts[0] in ("io", "catalog", "report", "ground", "tls", "plantation", "als",
                    "synthetic", "inventory"):
        return parts[0]
    return "top"  # cli, api, demo, fuzz


def _imports(f: Path, module: str, is_pkg: bool) -> set:
    """Every lidartrees_gis module ``f`` imports, at load time or inside a function."""
    base = module.split(".") if is_pkg else module.split(".")[:-1]
    out = set()
    for node in ast.walk(ast.parse(f.read_text())):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                target = base[:len(base) - node.level + 1] + ([node.module] if node.module else [])
                target = ".".join(target)
            else:
                target = node.module or ""
            if target.startswith("lidartrees_gis"):
                for a in node.names:  # "from . import x" imports the module x
                    sub = f"{target}.{a.name}"
                    out.add(sub if (PKG / Path(*sub.split(".")[1:])).with_suffix(".py").exists()
                            or (PKG / Path(*sub.split(".")[1:])).is_dir() else target)
        elif isinstance(node, ast.Import):
            out.update(a.name for a in node.names if a.name.startswith("lidartrees_gis"))
    out.discard(module)
    return out


def _graph() -> dict:
    return {m: _imports(f, m, f.name == "__init__.py") for f, m in _modules()}


def test_no_module_is_over_600_lines():
    long = {m: n for f, m in _modules() if (n := len(f.read_text().splitlines())) > 600}
    assert not long


def test_no_import_circle():
    graph = _graph()
    # Tarjan's strongly connected components
    index, low, stack, on, sccs, counter = {}, {}, [], set(), [], [0]

    def visit(v):
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in graph.get(v, ()):
            if w not in graph:
                continue
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
            sccs.append(comp)

    sys.setrecursionlimit(10_000)
    for v in graph:
        if v not in index:
            visit(v)
    circles = [sorted(c) for c in sccs if len(c) > 1]
    assert not circles


def test_imports_go_downwards_only():
    wrong = []
    for module, deps in _graph().items():
        room = _room(module)
        for d in deps:
            r = _room(d)
            if r != room and r not in ROOMS[room]:
                wrong.append(f"{module} ({room}) imports {d} ({r})")
    assert not wrong


def test_the_command_table_loads_only_the_standard_library():
    code = ("import sys; import lidartrees_gis.cli.commands as c; "
            "print(len(c.COMMANDS), sorted(m for m in sys.modules if m.split('.')[0] in "
            "('numpy', 'rasterio', 'pyproj', 'shapely', 'laspy', 'scipy', 'pandas')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=ROOT).stdout.split(" ", 1)
    assert int(out[0]) >= 11 and out[1].strip() == "[]"


@pytest.mark.parametrize("room", ["io", "catalog", "report", "ground", "tls", "als"])
def test_every_room_is_a_package_with_a_docstring(room):
    init = PKG / room / "__init__.py"
    assert init.exists()
    mods = [f for f in (PKG / room).glob("*.py")]
    assert all(ast.get_docstring(ast.parse(f.read_text())) for f in mods if f.name != "__init__.py")


def test_every_field_parameter_names_a_layer_of_its_command():
    """A field parameter (a dropdown of its layer's fields in QGIS) names a vector parameter
    of the same command, and the files a command declares are named in its library result."""
    from lidartrees_gis.cli.commands import COMMANDS
    from lidartrees_gis.inventory.volume import side_outputs

    fields = [(c.name, p) for c in COMMANDS.values() for p in c.params if p.kind == "field"]
    assert {(c, p.name) for c, p in fields} >= {("volume", "plot_id"), ("volume", "stand_id"),
                                                ("metrics", "plot_id"), ("trees", "stand_id")}
    for name, p in fields:
        kinds = {q.name: q.kind for q in COMMANDS[name].params}
        assert kinds.get(p.parent) == "vector", (name, p.name, p.parent)
    assert {k for k, _, _ in COMMANDS["volume"].files} == set(side_outputs("v.gpkg"))
    assert all(kind in ("raster", "file") for c in COMMANDS.values() for _, kind, _ in c.files)
