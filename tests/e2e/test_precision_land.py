"""gcs_examples/precision_land.py as a user runs it: a pymavlink companion computer reports a
landing pad in LANDING_TARGET and switches to Precision Land (DO_SET_MODE AUTO/PRECLAND); PX4's
precland flies over the pad and lands on it, or, with no pad, searches and lands where it is."""

import re
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

SCRIPT = Path(__file__).resolve().parents[2] / "gcs_examples" / "precision_land.py"


def _run(d, *args: str) -> str:
    try:
        out = subprocess.run([sys.executable, str(SCRIPT), "--port", str(d.api_port(0)), *args],
                             capture_output=True, text=True, timeout=240, stdin=subprocess.DEVNULL)
    except subprocess.TimeoutExpired as exc:
        pytest.fail(f"still running:\n{exc.stdout}\n{exc.stderr}\n{d.log_tail()}")
    assert out.returncode == 0, f"{out.stdout}\n{out.stderr}\n{d.log_tail()}"
    return out.stdout


def test_precision_land_on_a_reported_pad(daemon_factory):
    d = daemon_factory("--speed", "4")
    stdout = _run(d, "--north", "6", "--east", "-4")
    miss = float(re.search(r"Landed and disarmed ([0-9.]+) m from the pad", stdout).group(1))
    assert miss < 0.5, stdout


def test_precision_land_without_a_pad_searches_then_lands(daemon_factory):
    d = daemon_factory("--speed", "4")
    stdout = _run(d, "--no-target")
    m = re.search(r"\(([-0-9.]+) m N, ([-0-9.]+) m E of the takeoff point\)", stdout)
    assert abs(float(m.group(1))) < 1.0 and abs(float(m.group(2))) < 1.0, stdout
