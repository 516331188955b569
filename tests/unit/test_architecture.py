"""The layering docs/architecture.md describes, checked on the source: sans-IO cores, imports
that flow one way between rooms, no import circle, small modules."""

from __future__ import annotations

import ast
import pathlib
import shutil
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
PACKAGES = ("netsim", "vehicles", "gateway")
# Cores: simulated time only, no I/O (STYLE: sans-IO protocol logic, time is an argument).
CORES = ["netsim", "vehicles", "gateway/mavlink", "gateway/sim"]
FORBIDDEN_IN_CORES = {"asyncio", "socket", "selectors", "threading", "random"}
WALL_CLOCK_CALLS = {("time", "time"), ("time", "monotonic"), ("time", "perf_counter"),
                    ("time", "sleep"), ("datetime", "now")}
# gateway's rooms, lowest first: a room imports only from rooms before it (and from vehicles/
# and netsim/). The loose modules at the top (cli, the public aliases) may import any room.
ROOMS = ["gateway.data", "gateway.mavlink", "gateway.sim", "gateway.onboard", "gateway.bus",
         "gateway.web",
         "gateway.daemon", "gateway.ci"]
MAX_LOOSE_GATEWAY_MODULES = 8
MAX_MODULE_LINES = 500


def source_files(package: str) -> list[pathlib.Path]:
    return sorted(p for p in (ROOT / package).rglob("*.py") if "build" not in p.parts)


def module_name(path: pathlib.Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


PRODUCT = {module_name(p): p for pkg in PACKAGES for p in source_files(pkg)}


def imported(path: pathlib.Path) -> set[str]:
    """Every module an import statement in ``path`` names — at any depth (inside functions and
    ``if TYPE_CHECKING:`` too), relative imports resolved, ``from pkg import mod`` as pkg.mod."""
    this = module_name(path)
    package = this if path.name == "__init__.py" else this.rpartition(".")[0]
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")
                anchor = anchor[:len(anchor) - (node.level - 1)]
                base = ".".join(anchor + ([base] if base else []))
            names.add(base)
            for a in node.names:
                if f"{base}.{a.name}" in PRODUCT:
                    names.add(f"{base}.{a.name}")
    return names


def product_imports(path: pathlib.Path) -> set[str]:
    return {n for n in imported(path) if n in PRODUCT and n != module_name(path)}


GRAPH = {name: product_imports(path) for name, path in PRODUCT.items()}


@pytest.mark.parametrize("core", CORES)
def test_cores_are_sans_io(core):
    for path in source_files(core):
        roots = {name.split(".")[0] for name in imported(path)}
        bad = roots & FORBIDDEN_IN_CORES
        assert not bad, f"{path.relative_to(ROOT)} imports {bad}"
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) \
                    and isinstance(node.func.value, ast.Name):
                call = (node.func.value.id, node.func.attr)
                assert call not in WALL_CLOCK_CALLS, f"{path.relative_to(ROOT)}:{node.lineno} calls {call}"


@pytest.mark.parametrize("package, must_not", [
    ("netsim", {"gateway", "vehicles", "pymavlink"}),
    ("vehicles", {"gateway", "netsim", "pymavlink"}),
])
def test_imports_flow_one_way(package, must_not):
    for path in source_files(package):
        roots = {name.split(".")[0] for name in imported(path)}
        assert not roots & must_not, f"{path.relative_to(ROOT)} imports {roots & must_not}"


def room_of(module: str) -> int | None:
    for rank, room in enumerate(ROOMS):
        if module == room or module.startswith(room + "."):
            return rank
    return None


def test_gateway_rooms_import_downwards_only():
    wrong = []
    for name, deps in GRAPH.items():
        rank = room_of(name)
        if rank is None:
            continue
        for dep in deps:
            dep_rank = room_of(dep)
            if dep.startswith("gateway") and (dep_rank is None or dep_rank > rank):
                wrong.append(f"{name} imports {dep}")
    assert not wrong, "\n".join(wrong)


def test_no_import_circle():
    """Tarjan's strongly connected components over the product's import graph."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    circles: list[list[str]] = []
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10 * len(GRAPH)))

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in GRAPH[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                circles.append(sorted(component))

    for v in sorted(GRAPH):
        if v not in index:
            visit(v)
    assert not circles, "import circles: " + "; ".join(" <-> ".join(c) for c in circles)


def test_the_mavlink_services_never_import_their_session():
    """A service gets a LinkContext (gateway/mavlink/link.py), not the Session above it."""
    importers = sorted(name for name, deps in GRAPH.items()
                       if name.startswith("gateway.mavlink.") and "gateway.mavlink.session" in deps)
    assert importers == [], importers


def test_nothing_below_the_vehicle_imports_it():
    """The step goes World -> Vehicle -> Autopilot -> flight task and returns a command; the
    autopilot and what it owns never reach back up to the Vehicle or the World."""
    up = {"vehicles.vehicle", "vehicles.physics", "vehicles.world"}
    below = sorted(name for name, deps in GRAPH.items()
                   if name.startswith("vehicles.") and name not in up and deps & up)
    assert below == [], below


def test_no_private_attribute_of_a_vehicle_is_read_outside_it():
    """``vehicle._x`` / ``v._x`` only inside vehicles/vehicle.py."""
    offenders = []
    for package in PACKAGES:
        for path in source_files(package):
            if path == ROOT / "vehicles" / "vehicle.py":
                continue
            for node in ast.walk(ast.parse(path.read_text())):
                if (isinstance(node, ast.Attribute) and node.attr.startswith("_")
                        and not node.attr.startswith("__")
                        and isinstance(node.value, ast.Name) and node.value.id in ("vehicle", "v")):
                    offenders.append(f"{path.relative_to(ROOT)}:{node.lineno} {node.value.id}.{node.attr}")
    assert offenders == [], offenders


def test_the_graph_sees_known_edges():
    """The checker itself: it must see a lazy import and a TYPE_CHECKING one."""
    assert "gateway.mavlink.session" in GRAPH["gateway.sim.simulation"]
    assert "vehicles.geodesy" in GRAPH["vehicles.types"]


def test_few_loose_modules_in_gateway():
    loose = sorted(p.name for p in (ROOT / "gateway").glob("*.py"))
    assert len(loose) <= MAX_LOOSE_GATEWAY_MODULES, loose


@pytest.mark.parametrize("package", PACKAGES)
def test_no_module_over_500_lines(package):
    big = {str(p.relative_to(ROOT)): n for p in source_files(package)
           if (n := len(p.read_text().splitlines())) > MAX_MODULE_LINES}
    assert not big, big


def test_product_cites_nothing_outside_the_repository():
    out = subprocess.run(["git", "grep", "-nE", "shared/|PX4_COMPAT", "--", ":!tests"],
                         cwd=ROOT, capture_output=True, text=True)
    if out.returncode not in (0, 1):
        pytest.skip(f"git grep unavailable here (not a git checkout): {out.stderr.strip()}")
    assert out.stdout == "", out.stdout


def test_daemon_does_not_use_mavutil():
    for path in source_files("gateway"):
        assert "pymavlink.mavutil" not in imported(path) and "mavutil" not in path.read_text(), path


def _tool(name: str) -> str:
    exe = shutil.which(name) or str(pathlib.Path(sys.executable).parent / name)
    if not pathlib.Path(exe).exists():
        pytest.skip(f"{name} missing: `pip install {name}` (the test extra installs it)")
    return exe


def test_lint_is_clean():
    """ruff (configured in pyproject.toml) finds nothing."""
    out = subprocess.run([_tool("ruff"), "check", "--quiet", str(ROOT)], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout[-3000:]
