"""Suite-wide: compile the vehicles' numba kernels once before the workers start, and name
every end-to-end test and its outcome at the end of the run, so a CI log shows that the
real-client flights ran (and were not skipped)."""

_e2e_outcomes: list[tuple[str, str]] = []


def pytest_runtest_logreport(report):
    if "tests/e2e/" not in report.nodeid:
        return
    if report.when == "call" or (report.when == "setup" and report.outcome != "passed"):
        _e2e_outcomes.append((report.nodeid, report.outcome.upper()))


def pytest_terminal_summary(terminalreporter):
    if not _e2e_outcomes:
        return
    terminalreporter.section("end-to-end tests (real clients against `cornet run`)")
    for nodeid, outcome in _e2e_outcomes:
        terminalreporter.write_line(f"{outcome:8} {nodeid}")


def pytest_sessionstart(session):
    """In the controller (or a run without workers), before xdist starts its workers: one step of
    a simulated vehicle compiles every numba kernel a vehicle uses into numba's cache. On a
    fresh checkout the workers and the daemons the end-to-end tests start would otherwise each
    compile them at once (~15 s of CPU each), and a daemon could miss its ready time-out."""
    if hasattr(session.config, "workerinput"):
        return
    from gateway.sim.simulation import Simulation

    sim = Simulation(1)
    try:
        sim.run(until=0.05)
    finally:
        sim.close()
