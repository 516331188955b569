"""The live view end to end: `cornet run --web` as a user starts it, three vehicles taking off,
the page in a headless Chromium (Debian's chromium and chromedriver, driven by Selenium); and
`cornet web` against a daemon's ZeroMQ bus."""

import json
import os
import shutil
import socket
import subprocess
import threading
import time
import urllib.request
from pathlib import Path

import pytest

from gateway.ci.launcher import cornet_command, free_port_offset, free_tcp_port
from tests.e2e.gcs import arm_and_take_off, gcs

pytestmark = [pytest.mark.e2e, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[2]
# vehicle 1 loses every link at t = 40 s for 15 s
BLACKOUT = ROOT / "scenarios" / "blackout.toml"
WAIT_S = 120.0  # a bound on each wait in wall-clock seconds, never a measurement


def browser():
    """A headless Chromium under chromedriver, or a skip naming what is missing."""
    chromium = next((p for p in map(shutil.which, ("chromium", "chromium-browser")) if p), None)
    driver = shutil.which("chromedriver")
    missing = [name for name, path in (("chromium", chromium),
                                       ("chromedriver (Debian: chromium-driver)", driver))
               if path is None]
    if missing:
        pytest.skip(f"{' and '.join(missing)} missing: apt-get install chromium chromium-driver "
                    "(`make test` does as root)")
    webdriver = pytest.importorskip("selenium.webdriver",
                                    reason="selenium missing: pip install 'cornet[test]'")
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage",
                "--window-size=1400,900"):
        options.add_argument(arg)
    return webdriver.Chrome(service=Service(driver), options=options)


def vehicles_in_page(page) -> dict[str, dict]:
    """The side panel's vehicles: name -> the data attributes (north, east, alt, mode …)."""
    return page.execute_script("""
        const out = {};
        for (const li of document.querySelectorAll('#vehicles li.vehicle'))
          out[li.querySelector('.name').textContent] = {...li.dataset};
        return out;""")


def link_state(page, link: str) -> str | None:
    return page.execute_script(
        "const li = document.querySelector(`#links li[data-link='${arguments[0]}']`);"
        "return li ? li.dataset.state : null;", link)


def take_off(port: int, sysid: int, failures: list) -> None:
    conn = gcs(port)  # the vehicle's API link, as MAVSDK would listen
    try:
        arm_and_take_off(conn, above_m=1.0, timeout_s=60.0, target=sysid)
    except BaseException as exc:  # reported by the test thread
        failures.append((sysid, exc))
    finally:
        conn.close()


def test_live_view_of_three_vehicles_and_a_blackout(daemon_factory):
    page = browser()
    try:
        from selenium.webdriver.support.ui import WebDriverWait

        port = free_tcp_port()
        d = daemon_factory("--web", f"127.0.0.1:{port}", "--scenario", str(BLACKOUT),
                           "--speed", "2", vehicles=3)
        page.get(f"http://127.0.0.1:{port}/")
        names = ["vehicle 1", "vehicle 2", "vehicle 3"]
        WebDriverWait(page, WAIT_S).until(lambda p: sorted(vehicles_in_page(p)) == names)
        for name in names:  # in the panel's text, as a user reads it
            assert name in page.find_element("id", "vehicles").text
        before = vehicles_in_page(page)
        assert all(v["armed"] == "false" for v in before.values()), before

        failures: list = []
        pilots = [threading.Thread(target=take_off, args=(d.mavsdk_port(i), i + 1, failures))
                  for i in range(3)]
        for t in pilots:
            t.start()
        for t in pilots:
            t.join()
        assert not failures, failures
        WebDriverWait(page, WAIT_S).until(
            lambda p: all(float(v["alt"]) > 1.0 for v in vehicles_in_page(p).values()))
        after = vehicles_in_page(page)
        for name in names:
            was, now = before[name], after[name]
            assert (now["north"], now["east"], now["alt"]) != (was["north"], was["east"],
                                                               was["alt"]), (name, was, now)
            assert now["armed"] == "true", (name, now)

        # The blackout (t = 40 s … 55 s): vehicle 1's links turn to the loss colour, the others
        # stay up.
        WebDriverWait(page, WAIT_S).until(lambda p: link_state(p, "v1/gcs") == "lost")
        assert link_state(page, "v2/gcs") == "good" and link_state(page, "v3/gcs") == "good"
        swatch = page.execute_script("""
            const colour = (sel) => getComputedStyle(document.querySelector(sel)).backgroundColor;
            return [colour("#links li[data-link='v1/gcs'] .swatch"),
                    colour("#legend li.state-lost .swatch"),
                    colour("#links li[data-link='v2/gcs'] .swatch")];""")
        assert swatch[0] == swatch[1] != swatch[2], swatch
        WebDriverWait(page, WAIT_S).until(
            lambda p: "v1/gcs lost" in p.find_element("id", "events").text)
        # The map is drawn: the canvas is not blank.
        inked = page.execute_script("""
            const c = document.getElementById('map');
            const px = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
            let n = 0;
            for (let k = 3; k < px.length; k += 4) n += px[k] > 0;
            return n;""")
        assert inked > 100
        errors = [e for e in page.get_log("browser") if e["level"] == "SEVERE"]
        assert not errors, errors
    finally:
        page.quit()


def get_json(url: str) -> dict:
    with urllib.request.urlopen(url, timeout=5) as r:
        return json.load(r)


def test_cornet_web_shows_a_daemon_through_its_zeromq_bus(daemon_factory):
    endpoint = f"tcp://127.0.0.1:{free_tcp_port()}"
    daemon_factory("--zmq-pub", endpoint, "--scenario", "far-ap",
                   vehicles=2)
    port = free_tcp_port()
    web = subprocess.Popen(cornet_command() + ["web", "--zmq", endpoint, "--listen",
                                               f"127.0.0.1:{port}"],
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert web.stdout is not None
        line = web.stdout.readline()
        assert line.startswith(f"cornet web: http://127.0.0.1:{port}/ shows {endpoint}"), line
        snapshot: dict = {}
        for _ in range(100):  # until both vehicles and a link interval arrived
            snapshot = get_json(f"http://127.0.0.1:{port}/state.json")
            if len(snapshot["vehicles"]) == 2 and snapshot["links"]:
                break
            time.sleep(0.2)
        assert [v["sysid"] for v in snapshot["vehicles"]] == [1, 2]
        assert [(n["name"], n["kind"]) for n in snapshot["nodes"]] == [("ap", "ap")]
        assert {link["link"] for link in snapshot["links"]} == {"v1/gcs", "v1/api", "v2/gcs",
                                                                 "v2/api"}
        assert snapshot["server"]["source"] == endpoint
    finally:
        web.terminate()
        out, err = web.communicate(timeout=10)
    assert web.returncode == 0, err
    assert "Traceback" not in err, err


def test_a_taken_web_port_exits_2_with_one_line():
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        out = subprocess.run(cornet_command() + ["run", "--web", f"127.0.0.1:{port}",
                                                 "--port-offset", str(free_port_offset(1))],
                             capture_output=True, text=True, timeout=120)
    assert out.returncode == 2, out.stderr
    last = out.stderr.strip().splitlines()[-1]
    assert last == f"cornet: --web 127.0.0.1:{port}: Address already in use; choose a free port"


def test_without_aiohttp_the_live_view_exits_2_naming_it(tmp_path):
    """Where the [web] extra is not installed: the flag, `cornet web` and the configuration
    file's daemon.web each exit 2 with one line that says what to install."""
    shim = tmp_path / "shim" / "aiohttp"
    shim.mkdir(parents=True)
    (shim / "__init__.py").write_text(
        "raise ModuleNotFoundError(\"No module named 'aiohttp'\", name='aiohttp')\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(shim.parent), str(ROOT)])}
    config = tmp_path / "web.toml"
    config.write_text('[daemon]\nweb = "127.0.0.1:8080"\n')
    want = "the live view needs aiohttp: pip install 'cornet[web]'"
    offset = str(free_port_offset(1))
    for args, last in (
        (["run", "--web", "8080"], f"cornet run: error: argument --web: {want}"),
        (["web"], f"cornet web: {want}"),
        (["run", "--config", str(config), "--port-offset", offset], f"cornet: {want}"),
    ):
        out = subprocess.run(cornet_command() + args, capture_output=True, text=True,
                             timeout=120, env=env)
        assert out.returncode == 2, (args, out.stderr)
        assert out.stderr.strip().splitlines()[-1] == last, (args, out.stderr)
        assert "Traceback" not in out.stderr, out.stderr
