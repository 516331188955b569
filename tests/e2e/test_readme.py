"""README's quick start works as written: with the daemon `make run` starts, every command of
the "Fly it" block, then the "Flight regression in CI" block, run as the README shows them
(PX4 SITL's default ports, paths relative to the checkout, `.venv/bin/...`), each with a
time-out, and each must exit 0.

Default ports may be taken on a shared machine (a PX4 SITL, another cornet): the commands then
run in a network namespace of their own (`unshare -rn`), which needs unprivileged user
namespaces or root; without one and with the ports taken, the test skips and says why."""

import json
import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from gateway.ci.ports import daemon_ports, udp_free

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"
SECTIONS = ("## Fly it", "## Flight regression in CI")
COMMAND_TIMEOUT_S = 300
DRIVER = Path(__file__).parent / "clients" / "readme_driver.py"


def code_block(text: str, heading: str) -> list[str]:
    """The command lines of the first ```sh block under ``heading``, comments removed."""
    section = text.split(f"\n{heading}\n", 1)[1]
    block = re.search(r"```sh\n(.*?)```", section, re.S)
    assert block, f"README: no ```sh block under {heading!r}"
    lines = [re.sub(r"\s+#.*$", "", line).strip() for line in block.group(1).splitlines()]
    return [line for line in lines if line and not line.startswith("#")]


def quick_start() -> list[str]:
    text = README.read_text()
    return [line for heading in SECTIONS for line in code_block(text, heading)]


def make_run_command() -> list[str]:
    """What `make run` runs (the Makefile's recipe), with its defaults."""
    recipe = re.search(r"^run: .*\n\t(.+)$", (ROOT / "Makefile").read_text(), re.M)
    assert recipe, "Makefile: no run recipe"
    words = recipe.group(1).replace("$(VENV)", ".venv").replace("$(VEHICLES)", "1")
    words = words.replace("$(PORT_OFFSET)", "0").replace("$(STATE_DIR)", "state")
    return shlex.split(words)


def test_the_quick_start_blocks_are_what_this_test_runs():
    lines = quick_start()
    assert lines == [
        ".venv/bin/python gcs_examples/takeoff_and_land.py",
        ".venv/bin/python gcs_examples/params.py",
        ".venv/bin/python gcs_examples/mission.py",
        ".venv/bin/python gcs_examples/download_log.py",
        ".venv/bin/cornet fly square",
        ".venv/bin/cornet plot logs/",
    ], lines
    assert make_run_command() == [".venv/bin/cornet", "run", "--vehicles", "1", "--port-offset",
                                  "0", "--state-dir", "state"]


def test_readme_quick_start_runs_as_written(tmp_path):
    # A checkout as the README's reader has it: gcs_examples/ and .venv/ (this interpreter's
    # environment) beside each other; logs/ lands here, not in the repository.
    venv = Path(sys.prefix)
    if not (venv / "bin" / "cornet").exists():
        pytest.skip(f"{venv} has no cornet script: install the project in it (make test does)")
    (tmp_path / ".venv").symlink_to(venv)
    (tmp_path / "gcs_examples").symlink_to(ROOT / "gcs_examples")
    plan = {"daemon": make_run_command(), "commands": quick_start(),
            "timeout_s": COMMAND_TIMEOUT_S}
    args = [sys.executable, str(DRIVER), json.dumps(plan)]
    if not all(udp_free(p) for p in daemon_ports(0, 1)):
        if shutil.which("unshare") is None or shutil.which("ip") is None:
            pytest.skip("PX4 SITL's default ports are taken here and there is no unshare/ip "
                        "for a network namespace of the test's own")
        args = ["unshare", "-rn", "sh", "-c", 'ip link set lo up && exec "$@"', "sh", *args]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        [str(ROOT), *filter(None, [os.environ.get("PYTHONPATH")])])}
    out = subprocess.run(args, cwd=tmp_path, capture_output=True, text=True, env=env,
                         timeout=COMMAND_TIMEOUT_S * (len(plan["commands"]) + 1))
    if out.returncode == 3:
        pytest.skip(out.stdout.strip().splitlines()[-1])
    assert out.returncode == 0, out.stdout[-6000:] + out.stderr[-3000:]
    for command in plan["commands"]:
        assert f"PASS {command}" in out.stdout, out.stdout[-6000:]
    assert {"track.png", "altitude_speed.png", "link.png"} <= {
        p.name for p in (tmp_path / "logs").iterdir()}


def test_the_wheel_block_is_what_test_wheel_runs():
    """README's "from the wheel" commands are those tests/e2e/test_wheel.py runs in a fresh
    venv outside the repository (that test builds and installs the wheel)."""
    text = README.read_text()
    section = text.split("Without the checkout, from the wheel", 1)[1]
    block = re.search(r"```sh\n(.*?)```", section, re.S)
    assert block
    lines = [re.sub(r"\s+#.*$", "", line).strip() for line in block.group(1).splitlines()]
    assert lines == ["pip install cornet-0.1.0-py3-none-any.whl", "cornet --version",
                     "cornet scenarios", "cornet run --scenario lossy-wifi",
                     "cornet fly square && cornet plot logs/",
                     "pip install 'cornet-0.1.0-py3-none-any.whl[mpi]'",
                     "cornet run --vehicles 4 --shards 2"], lines
