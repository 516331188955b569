"""Suite-wide: name every end-to-end test and its outcome at the end of the run, so a CI log
shows that the real-client flights ran (and were not skipped)."""

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
