"""CI reports of ``cornet fly`` and ``cornet sweep``: JUnit XML and a Markdown job summary.

JUnit XML as CI servers read it: ``<testsuites>`` holding one ``<testsuite>`` with one
``<testcase>`` per flight (a ``fly``, or each cell and seed of a ``sweep``); a failed flight or a
regression has a ``<failure message="...">`` whose message carries the numbers, and the full
report as its text. The Markdown summary is a table of the same cases, for a CI job summary
(e.g. appended to the file ``$GITHUB_STEP_SUMMARY`` names, or published as an artifact).

Exit codes of both commands: 0 every flight passed, 1 a flight failed or regressed, 2 bad input.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

EXIT_PASS, EXIT_FAIL, EXIT_BAD_INPUT = 0, 1, 2


@dataclass(frozen=True)
class Case:
    """One flight as a test case."""

    name: str  # e.g. "latency 100 ms, loss 0.2, seed 1"
    classname: str  # e.g. "cornet.sweep.square"
    time_s: float  # wall-clock seconds the flight took
    failure: str | None = None  # one line with the numbers; None: passed
    details: str = ""  # the full report (the failure's text, or system-out)


def junit_xml(suite: str, cases: Sequence[Case]) -> str:
    failures = sum(c.failure is not None for c in cases)
    total_s = sum(c.time_s for c in cases)
    root = ET.Element("testsuites", name="cornet", tests=str(len(cases)),
                      failures=str(failures), errors="0", time=f"{total_s:.3f}")
    ts = ET.SubElement(root, "testsuite", name=suite, tests=str(len(cases)),
                       failures=str(failures), errors="0", skipped="0", time=f"{total_s:.3f}")
    for c in cases:
        tc = ET.SubElement(ts, "testcase", name=c.name, classname=c.classname,
                           time=f"{c.time_s:.3f}")
        if c.failure is not None:
            f = ET.SubElement(tc, "failure", message=c.failure, type="FlightRegression")
            f.text = c.details
        elif c.details:
            ET.SubElement(tc, "system-out").text = c.details
    ET.indent(root)
    return '<?xml version="1.0" encoding="utf-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def write_junit(path: str | Path, suite: str, cases: Sequence[Case]) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(junit_xml(suite, cases))
    return path


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def markdown_summary(title: str, cases: Sequence[Case], extra: str = "") -> str:
    failed = [c for c in cases if c.failure is not None]
    verdict = "passed" if not failed else f"{len(failed)} of {len(cases)} failed"
    lines = [f"## {title}: {'✅' if not failed else '❌'} {verdict}", "",
             "| flight | result | details |", "|---|---|---|"]
    for c in cases:
        detail = c.failure if c.failure is not None else (c.details.splitlines() or [""])[0]
        lines.append(f"| {_cell(c.name)} | {'pass' if c.failure is None else '**fail**'} | "
                     f"{_cell(detail)} |")
    if extra:
        lines += ["", extra]
    return "\n".join(lines) + "\n"


def write_summary(path: str | Path, title: str, cases: Sequence[Case], extra: str = "") -> Path:
    """Append the summary to ``path`` (CI job summary files collect several steps)."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path, "a") as f:
        f.write(markdown_summary(title, cases, extra))
    return path
