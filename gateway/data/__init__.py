"""The files CORNET ships inside its package: scenarios, example QGroundControl plans, the systemd
unit and its example configuration. In the checkout they live where users look for them
(scenarios/, gcs_examples/plans/, systemd/); ``scenarios``, ``plans`` and ``systemd`` here are
links to those directories, and the wheel carries their files. ``cornet run --scenario NAME`` and
``cornet fly NAME`` find them by name, and by their checkout paths (``scenarios/NAME.toml``,
``gcs_examples/plans/NAME.plan``) outside the checkout; a path that exists always wins."""

from __future__ import annotations

from pathlib import Path

DATA_DIR = Path(__file__).resolve().parent
SCENARIO_DIR = DATA_DIR / "scenarios"
PLAN_DIR = DATA_DIR / "plans"
SYSTEMD_DIR = DATA_DIR / "systemd"


# Where the checkout kept these files before they moved into the package: such a path (from
# older docs and scripts) that does not exist finds the shipped file of its name.
FORMER_DIRS = {SCENARIO_DIR: "scenarios", PLAN_DIR: "gcs_examples/plans"}


def _builtin(directory: Path, suffix: str, text: str | Path) -> Path | None:
    """The shipped file ``text`` names (``lossy-wifi`` or ``lossy-wifi.toml``, or its former
    path ``scenarios/lossy-wifi.toml``), if any."""
    name = str(text)
    parent, _, base = name.rpartition("/")
    former = FORMER_DIRS.get(directory)
    if former is not None and parent and (parent == former or parent.endswith("/" + former)):
        name = base
    if "/" in name or "\\" in name or not name:
        return None
    if not name.endswith(suffix):
        name += suffix
    path = directory / name
    return path if path.is_file() else None


def resolve(text: str | Path, directory: Path, suffix: str) -> Path:
    """A path that exists as given, else the shipped file of that name, else the path as given
    (whose reader then says it cannot read it)."""
    path = Path(text)
    if path.exists():
        return path
    return _builtin(directory, suffix, text) or path


def scenario_path(text: str | Path) -> Path:
    return resolve(text, SCENARIO_DIR, ".toml")


def plan_path(text: str | Path) -> Path:
    return resolve(text, PLAN_DIR, ".plan")


def scenario_names() -> list[str]:
    return sorted(p.stem for p in SCENARIO_DIR.glob("*.toml"))


def summary(path: Path) -> str:
    """What a shipped file is, in one line: the first line of its leading ``#`` comment."""
    first = path.read_text(encoding="utf-8").splitlines()[:1]
    return first[0].lstrip("#").strip() if first and first[0].startswith("#") else ""
