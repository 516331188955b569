"""List the parameters of vehicles/data/px4_params.csv that PX4 marks reboot_required, from a
PX4 source tree: ``@reboot_required true`` in a *_params.c comment block (the PARAM_DEFINE that
follows it) and ``reboot_required: true`` under a parameter of a module.yaml (names with
``${i}`` instances are expanded over their ``num_instances``, from ``instance_start``).

Run:  python tools/make_reboot_required.py PX4_SRC_DIR vehicles/data/px4_params.csv \
          vehicles/data/px4_reboot_required.txt
"""

from __future__ import annotations

import csv
import re
import sys
from pathlib import Path

_DEFINE = re.compile(r"PARAM_DEFINE_(?:INT32|FLOAT)\(\s*(\w+)")


def from_c(text: str) -> set[str]:
    out, pending = set(), False
    for line in text.splitlines():
        if "@reboot_required true" in line:
            pending = True
        m = _DEFINE.search(line)
        if m:
            if pending:
                out.add(m.group(1))
            pending = False
    return out


def from_yaml(text: str) -> set[str]:
    """Parameter blocks of a module.yaml: a key under ``definitions:`` whose block says
    ``reboot_required: true`` (indentation-based, as the files are written)."""
    out: set[str] = set()
    lines = text.splitlines()
    for i, line in enumerate(lines):
        m = re.match(r"^(\s+)([A-Z0-9_${}]+):\s*$", line)
        if not m:
            continue
        indent, name = len(m.group(1)), m.group(2)
        block, count, start = [], 1, 0
        for later in lines[i + 1:]:
            if later.strip() and len(later) - len(later.lstrip()) <= indent:
                break
            block.append(later)
        body = "\n".join(block)
        if not re.search(r"^\s+reboot_required:\s*true\s*$", body, re.M):
            continue
        n = re.search(r"num_instances:\s*(\d+)", body)
        s = re.search(r"instance_start:\s*(\d+)", body)
        count = int(n.group(1)) if n else 1
        start = int(s.group(1)) if s else 0
        if "${i}" in name:
            out.update(name.replace("${i}", str(k)) for k in range(start, start + count))
        else:
            out.add(name)
    return out


def main(src: str, table: str, dst: str) -> None:
    names: set[str] = set()
    for path in Path(src).rglob("*"):
        if path.suffix == ".c":
            names |= from_c(path.read_text(errors="replace"))
        elif path.suffix == ".yaml":
            names |= from_yaml(path.read_text(errors="replace"))
    with open(table, newline="") as f:
        ours = {row["name"] for row in csv.DictReader(f)}
    kept = sorted(names & ours)
    Path(dst).write_text("".join(f"{n}\n" for n in kept))
    print(f"{len(names)} reboot_required in PX4, {len(kept)} of ours -> {dst}")


if __name__ == "__main__":
    main(*sys.argv[1:4])
