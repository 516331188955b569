"""CORNET's pytest plugin: simulated PX4 vehicles as fixtures, assertions on their flight logs.

Installed with cornet (the ``pytest11`` entry point ``cornet``), or loaded by hand with
``pytest -p gateway.pytest_plugin``. Importing it does nothing else: no autouse fixture, one hook
(the ``--cornet-update-baselines`` option), and the simulator itself is imported only when a
fixture or helper needs it.

Fixtures (both are factories; everything they start is stopped at the end of the test):

``cornet_daemon(*args, vehicles=1)``
    ``cornet run`` as a subprocess on a free ``--port-offset``, with ``--log-dir`` in a temporary
    directory and ``args`` passed through (``"--speed", "10"``, ``"--scenario", FILE`` ...).
    Returns once the daemon printed its ``ready`` line: a :class:`CornetDaemon` with
    ``mavsdk_url(i)`` (``udpin://0.0.0.0:<port>`` for MAVSDK's ``connect``), ``gcs_url()``,
    ``pymavlink_url(i=None)`` (``udpin:0.0.0.0:<port>``, pymavlink's form: the GCS link, or
    vehicle i's API link), ``log_dir`` and ``stop()``. At teardown it is sent SIGTERM and must
    exit with code 0.

``cornet_sim(vehicles=1, **kwargs)``
    a lockstep :class:`gateway.ci.lockstep.Sim` (no sockets, simulated clock) logging to a directory
    under ``tmp_path`` (its ``log_dir`` attribute); closed at teardown.

``cornet_baseline(plan, directory=None, tolerances=None, **conditions)``
    flies ``plan`` in lockstep (``cornet fly``'s judge; ``conditions``: fields of
    ``gateway.ci.spec.FlightSpec`` such as ``latency_ms=100``, ``seed=1``, ``control="ground"``)
    and compares it with the baseline stored in ``directory`` (default: ``baselines/<test name>``
    next to the test file, gateway/ci/baseline.py): the test fails with the comparison report if
    the flight failed or changed beyond the tolerances. ``pytest --cornet-update-baselines``
    stores the flights as the new baselines instead (a failed flight is not stored). Returns the
    ``gateway.ci.regress.Outcome``.

Assertion helpers, on a run's logs (a run directory, a base directory holding runs, a
:class:`CornetDaemon`, a ``Sim`` or a :class:`FlightLogView`). ``reached`` and ``landed_within``
return a :class:`Check`, true or false, whose repr says what was measured, so a failing
``assert`` explains itself::

    assert reached(log, 47.398012, 8.545594, rel_alt_m=15, within_m=2)
    assert landed_within(log, "home", 2)          # or landed_within(log, lat, lon, 2)
    assert max_deviation_m(log, "mission.plan") < 3

Positions come from ``state.csv`` (10 Hz): the vehicle's local NED position from its EKF origin
(meta.json), projected to latitude/longitude as the simulator does (PX4's map projection); the
relative altitude is the height above that origin (where the vehicle spawned: its home).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from gateway.ci.checks import (
    Check,
    FlightLogView,
    StateSample,
    distance_m,
    landed_within,
    max_deviation_m,
    reached,
)
from gateway.ci.launcher import CornetDaemon, option, start_daemon
from gateway.ci.ports import free_port_offset, free_tcp_port

__all__ = ["Check", "CornetDaemon", "FlightLogView", "StateSample", "distance_m",
           "free_port_offset", "free_tcp_port", "landed_within", "max_deviation_m", "reached",
           "start_daemon"]


UPDATE_BASELINES = "--cornet-update-baselines"


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.getgroup("cornet").addoption(
        UPDATE_BASELINES, action="store_true", default=False,
        help="cornet_baseline: store the flights as the new baselines instead of comparing")


# --- fixtures ------------------------------------------------------------------------------------
@pytest.fixture
def cornet_daemon(tmp_path_factory: pytest.TempPathFactory):
    """Factory: ``cornet_daemon(*args, vehicles=None, log_dir=<tmp>, ...)`` → CornetDaemon
    (see :func:`start_daemon`); each one is stopped with SIGTERM at teardown and must exit 0."""
    started: list[CornetDaemon] = []

    def start(*args: str, vehicles: int | None = None, log_dir: str | Path | None = None,
              **kwargs: Any) -> CornetDaemon:
        if log_dir is None and option(args, "--log-dir") is None:
            log_dir = tmp_path_factory.mktemp("cornet-logs")
        try:
            d = start_daemon(*args, vehicles=vehicles, log_dir=log_dir, **kwargs)
        except RuntimeError as exc:  # it exited at start (bad flags, a port in use) or hung
            pytest.fail(str(exc), pytrace=False)
        started.append(d)
        return d

    yield start
    failed = []
    for d in started:
        code = d.stop()
        if code != 0:
            failed.append(f"{' '.join(d.command)}: exit code {code}\n{d.log_tail()}")
    assert not failed, "cornet run did not stop cleanly:\n" + "\n".join(failed)


@pytest.fixture
def cornet_sim(tmp_path: Path):
    """Factory: ``cornet_sim(vehicles=1, **kwargs)`` → a lockstep ``gateway.ci.lockstep.Sim``
    recording flight logs in ``tmp_path/sim-<n>`` (its ``log_dir`` attribute) unless
    ``log_dir`` is given (None: no logs). Closed at teardown."""
    sims: list[Any] = []

    def make(vehicles: int | None = 1, **kwargs: Any) -> Any:
        from gateway.ci.lockstep import Sim

        if "log_dir" not in kwargs:
            kwargs["log_dir"] = tmp_path / f"sim-{len(sims) + 1}"
        if kwargs.get("scenario") is not None and vehicles == 1:
            vehicles = None  # the scenario says how many
        sim = Sim(vehicles, **kwargs)  # the test may close it (``with sim:``) before the teardown
        sims.append(sim)
        return sim

    yield make
    for sim in sims:
        sim.close()


@pytest.fixture
def cornet_baseline(request: pytest.FixtureRequest):
    """Factory: ``cornet_baseline(plan, directory=None, tolerances=None, **conditions)`` → the
    ``gateway.ci.regress.Outcome`` of a lockstep flight compared with its stored baseline."""
    from gateway.ci import regress
    from gateway.ci.baseline import DEFAULT_TOLERANCES, MANIFEST

    update = bool(request.config.getoption(UPDATE_BASELINES))
    default_dir = Path(str(request.node.path)).parent / "baselines" / request.node.name

    def check(plan: str | Path, directory: str | Path | None = None, tolerances: Any = None,
              **conditions: Any) -> Any:
        where = Path(directory) if directory is not None else default_dir
        if not update and not (where / MANIFEST).is_file():
            pytest.fail(f"no baseline in {where}: record it with pytest {UPDATE_BASELINES}",
                        pytrace=False)
        outcome = regress.run(plan, conditions, baseline=None if update else where,
                              tolerances=tolerances or DEFAULT_TOLERANCES)
        if not outcome.passed:
            pytest.fail(outcome.text(), pytrace=False)
        if update:
            from gateway.ci.baseline import Baseline
            from gateway.ci.fly import load_plan

            Baseline.of(outcome.result, outcome.spec, load_plan(plan)).save(where)
        return outcome

    return check
