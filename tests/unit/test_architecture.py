"""The shape rules of STYLE.md, checked on the source: sans-IO cores, one-way imports."""

import ast
import pathlib

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
CORES = ["netsim", "vehicles", "gateway/mavlink"]
FORBIDDEN_IN_CORES = {"asyncio", "socket", "selectors", "threading", "random"}
WALL_CLOCK_CALLS = {("time", "time"), ("time", "monotonic"), ("time", "perf_counter"),
                    ("time", "sleep"), ("datetime", "now")}


def modules(package: str):
    return sorted((ROOT / package).rglob("*.py"))


def imported(path: pathlib.Path) -> set[str]:
    names = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            names |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module)
    return names


@pytest.mark.parametrize("core", CORES)
def test_cores_are_sans_io(core):
    for path in modules(core):
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
    for path in modules(package):
        roots = {name.split(".")[0] for name in imported(path)}
        assert not roots & must_not, f"{path.relative_to(ROOT)} imports {roots & must_not}"


def test_daemon_does_not_use_mavutil():
    for path in modules("gateway"):
        assert "pymavlink.mavutil" not in imported(path) and "mavutil" not in path.read_text(), path


def test_lint_is_clean():
    """ruff (configured in pyproject.toml) finds nothing; skipped only where ruff is absent."""
    import shutil
    import subprocess
    import sys

    ruff = shutil.which("ruff") or str(pathlib.Path(sys.executable).parent / "ruff")
    if not pathlib.Path(ruff).exists():
        pytest.skip("ruff missing: `pip install ruff` (the test extra installs it)")
    out = subprocess.run([ruff, "check", "--quiet", str(ROOT)], capture_output=True, text=True)
    assert out.returncode == 0, out.stdout[-3000:]
