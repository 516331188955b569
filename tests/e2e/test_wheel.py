"""What a new user gets from ``pip install cornet``: the wheel built from this tree, installed
alone in a fresh venv (no system site-packages; its dependencies from PyPI or pip's cache), used
from a directory outside the repository: the CLI, the pytest plugin, the ns-3 engine built from
the sources it carries; and with ``cornet[mpi]``, a sharded daemon."""

import contextlib
import json
import os
import re
import shutil
import subprocess
import sys
import urllib.request
from pathlib import Path

import pytest

from gateway.ci.launcher import CornetDaemon
from gateway.ci.ports import free_port_offset, free_tcp_port

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[2]
SOURCES = ("gateway", "vehicles", "netsim", "pyproject.toml", "README.md", "LICENSE")
INSTALL_TIMEOUT_S = 900


def sh(args, cwd, timeout=120, env=None):
    return subprocess.run([str(a) for a in args], cwd=cwd, capture_output=True, text=True,
                          timeout=timeout, env=env, stdin=subprocess.DEVNULL)


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    """The wheel built from a clean copy of this tree."""
    tmp = tmp_path_factory.mktemp("wheel")
    src = tmp / "src"
    src.mkdir()
    ignore = shutil.ignore_patterns("__pycache__", "build", "*.egg-info")
    for name in SOURCES:  # a clean copy: an in-tree build/ could carry stale files
        path = ROOT / name
        if path.is_dir():
            shutil.copytree(path, src / name, ignore=ignore)
        else:
            shutil.copy2(path, src / name)
    env = _clean_env()
    dist = tmp / "dist"
    out = sh([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", dist, src], tmp,
             timeout=INSTALL_TIMEOUT_S, env=env)
    assert out.returncode == 0, out.stderr
    (built,) = dist.glob("cornet-*.whl")
    return built


def _clean_env() -> dict[str, str]:
    return {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "VIRTUAL_ENV")}


def _install(tmp: Path, requirement: str) -> tuple[Path, Path, dict[str, str]]:
    """``requirement`` in a fresh venv: (its bin/, a working directory outside the
    repository, its environment)."""
    env = _clean_env()
    venv = tmp / "venv"
    out = sh([sys.executable, "-m", "venv", venv], tmp, env=env)
    assert out.returncode == 0, out.stderr
    assert "include-system-site-packages = false" in (venv / "pyvenv.cfg").read_text()
    # --no-compile: the same files, without pip byte-compiling every installed module
    # (Python does that on first import); it halves the install.
    out = sh([venv / "bin" / "python", "-m", "pip", "install", "-q", "--no-compile",
              "--disable-pip-version-check", requirement], tmp,
             timeout=INSTALL_TIMEOUT_S, env=env)
    assert out.returncode == 0, out.stderr
    work = tmp / "elsewhere"
    work.mkdir()
    env["NUMBA_CACHE_DIR"] = str(tmp / "numba-cache")
    return venv / "bin", work, env


@contextlib.contextmanager
def _serving(venv: tuple[Path, Path, dict[str, str]], vehicles: int, *args: str):
    """``cornet run ARGS`` from the venv, on a free port offset: the daemon once it is ready;
    stopped afterwards, and it must exit 0."""
    bin_dir, work, env = venv
    offset = free_port_offset(vehicles)
    cmd = [str(bin_dir / "cornet"), "run", *args, "--port-offset", str(offset)]
    proc = subprocess.Popen(cmd, cwd=work, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, stdin=subprocess.DEVNULL)
    daemon = CornetDaemon(proc, cmd, offset, vehicles, None)
    try:
        assert daemon.wait_ready(120), daemon.log_tail()
        yield daemon
    finally:
        code = daemon.stop()
    assert code == 0, daemon.log_tail()


@pytest.fixture(scope="module")
def installed(wheel, tmp_path_factory):
    """``pip install cornet``: the wheel alone."""
    return _install(tmp_path_factory.mktemp("base"), str(wheel))


@pytest.fixture(scope="module")
def installed_extras(wheel, tmp_path_factory):
    """``pip install 'cornet[mpi,web]'``: with mpi4py and MPICH's wheel (mpiexec in the venv),
    and aiohttp for the live view."""
    return _install(tmp_path_factory.mktemp("extras"), f"{wheel}[mpi,web]")


def test_version(installed):
    bin_dir, work, env = installed
    out = sh([bin_dir / "cornet", "--version"], work, env=env)
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("cornet 0."), out.stdout


def test_scenarios_lists_the_shipped_ones_and_check_finds_them_by_name(installed):
    bin_dir, work, env = installed
    out = sh([bin_dir / "cornet", "scenarios"], work, env=env)
    assert out.returncode == 0, out.stderr
    names = {line.split()[0] for line in out.stdout.splitlines() if line and line[0] != "`"}
    assert {"ideal", "lossy-wifi", "far-ap", "two-radios", "gps-loss"} <= names, out.stdout
    out = sh([bin_dir / "cornet", "check", "lossy-wifi"], work, env=env)
    assert out.returncode == 0, out.stderr
    assert out.stdout.splitlines()[0].endswith("lossy-wifi.toml: ok"), out.stdout
    assert "site-packages" in out.stdout.splitlines()[0], out.stdout


def test_run_a_shipped_scenario_by_name(installed):
    with _serving(installed, 2, "--scenario", "lossy-wifi") as daemon:
        pass
    # Nothing before the ready line on stdout (no PyBullet build banner), nor on stderr.
    assert daemon.stdout_lines[0].startswith("cornet ready: 2 vehicle(s)"), daemon.stdout_lines
    assert not any("pybullet build time" in line for line in daemon.output), daemon.log_tail()


def test_fly_then_plot_a_shipped_plan(installed):
    bin_dir, work, env = installed
    out = sh([bin_dir / "cornet", "fly", "square"], work, timeout=600, env=env)
    assert out.returncode == 0, out.stdout + out.stderr
    out = sh([bin_dir / "cornet", "plot", "logs"], work, timeout=300, env=env)
    assert out.returncode == 0, out.stdout + out.stderr
    assert {"track.png", "altitude_speed.png", "link.png"} <= {p.name for p in
                                                               (work / "logs").iterdir()}


def test_without_the_mpi_extra_shards_say_how_to_get_it(installed):
    bin_dir, work, env = installed
    out = sh([bin_dir / "cornet", "run", "--vehicles", "2", "--shards", "2", "--port-offset",
              str(free_port_offset(2))], work, env=env)
    assert out.returncode == 2, out.stdout + out.stderr
    assert "pip install 'cornet[mpi]'" in out.stderr, out.stderr


def test_the_mpi_extra_runs_a_sharded_daemon(installed_extras):
    """The venv's own mpiexec (MPICH's wheel) starts the job; nothing else is installed."""
    assert (installed_extras[0] / "mpiexec").exists()
    with _serving(installed_extras, 4, "--vehicles", "4", "--shards", "2") as daemon:
        pass
    assert daemon.stdout_lines[0].startswith("cornet ready: 4 vehicle(s) in 2 shards"), \
        daemon.stdout_lines


def test_the_ns3_engine_builds_from_the_installed_sources(installed):
    """An ns-3 scenario without the engine's build says how to make it from the sources the
    wheel carries; with Debian's ns-3 3.37 development files here, that command builds it in
    the installed package and the scenario then runs."""
    bin_dir, work, env = installed
    offset = free_port_offset(1)
    cmd = [str(bin_dir / "cornet"), "run", "--scenario", "ns3-wifi", "--port-offset",
           str(offset)]
    out = sh(cmd, work, env=env)
    assert out.returncode == 2, out.stdout + out.stderr
    m = re.search(r"build it with `make -C ([^`]+)`", out.stderr)
    assert m, out.stderr
    sources = Path(m.group(1))
    assert "site-packages" in sources.parts
    assert {"Makefile", "cornet_ns3.cc", "lte.cc", "lte.h", "json.h"} <= \
        {p.name for p in sources.iterdir()}
    if sh(["pkg-config", "--exists", "ns3-core", "ns3-wifi", "ns3-lte"], work).returncode != 0 \
            or not Path("/usr/include/zmq.hpp").exists():
        pytest.skip("ns-3 3.37's development files are not installed (make ns3-deps): the "
                    "build from the installed sources is not tried")
    built = sh(["make", "-C", sources], work, timeout=900, env=env)
    assert built.returncode == 0, built.stdout + built.stderr
    with _serving(installed, 1, "--scenario", "ns3-wifi") as daemon:
        pass
    assert "network=ns3" in daemon.stdout_lines[0], daemon.stdout_lines


def test_the_pytest_plugin_of_the_installed_wheel(installed, tmp_path):
    """A CI user's test file, run by pytest installed beside the wheel: the plugin comes from
    the wheel's entry point; a daemon flown with pymavlink and a lockstep flight, then the
    plugin's assertions on their logs."""
    bin_dir, work, env = installed
    out = sh([bin_dir / "python", "-m", "pip", "install", "-q", "--no-compile",
              "--disable-pip-version-check", "pytest"], work, timeout=INSTALL_TIMEOUT_S, env=env)
    assert out.returncode == 0, out.stderr
    suite = tmp_path / "ci"
    suite.mkdir()
    (suite / "test_flight.py").write_text('''
from pymavlink import mavutil

from gateway.ci.pytest_plugin import landed_within


def test_daemon_heartbeat(cornet_daemon):
    d = cornet_daemon()
    link = mavutil.mavlink_connection(d.pymavlink_url(), source_system=255)
    assert link.wait_heartbeat(timeout=20) is not None
    assert link.target_system == 1


def test_lockstep_takeoff_and_land(cornet_sim):
    sim = cornet_sim()
    api = sim.api(0)
    assert sim.run_until(lambda: sim.status(0).prearm_ok, timeout_s=30)
    assert api.arm() == 0
    assert api.takeoff() == 0
    assert sim.run_until(lambda: -sim.state(0).position_ned_m[2] > 2.0, timeout_s=60)
    assert api.land() == 0
    assert sim.run_until(lambda: not sim.status(0).armed, timeout_s=120)
    sim.close()
    assert landed_within(sim, "home", 2)
''')
    out = sh([bin_dir / "python", "-m", "pytest", "-q", "-p", "no:cacheprovider", suite], work,
             timeout=600, env=env)
    assert out.returncode == 0, out.stdout[-4000:] + out.stderr[-2000:]
    assert "2 passed" in out.stdout, out.stdout[-2000:]


def test_the_web_extra_serves_the_live_view(installed_extras):
    """The page and its script and style come from the installed package."""
    port = free_tcp_port()
    with _serving(installed_extras, 1, "--web", str(port)):
        page = urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=10).read().decode()
        assert "<canvas" in page, page[:500]
        names = re.findall(r'(?:src|href)="/static/([^"]+)"', page)
        assert {"live.js", "live.css"} <= set(names), names
        for name in names:
            body = urllib.request.urlopen(f"http://127.0.0.1:{port}/static/{name}",
                                          timeout=10).read()
            assert body, name
        state = json.loads(urllib.request.urlopen(f"http://127.0.0.1:{port}/state.json",
                                                  timeout=10).read())
        assert state, state
