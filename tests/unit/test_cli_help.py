"""`cornet --help` and every subcommand's help say what each option and argument is for."""

import argparse
import subprocess
import sys
from pathlib import Path

from gateway.cli import build_parser

ROOT = Path(__file__).resolve().parents[2]


def walk(parser: argparse.ArgumentParser, path: str):
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helped = {choice.dest for choice in action._choices_actions}
            for name, sub in action.choices.items():
                yield f"{path} {name}", name in helped
                yield from walk(sub, f"{path} {name}")
        else:
            yield f"{path} {'/'.join(action.option_strings) or action.dest}", \
                bool(action.help) and action.help != argparse.SUPPRESS


def test_every_subcommand_option_and_argument_has_help():
    seen = dict(walk(build_parser(), "cornet"))
    assert "cornet run --param-file" in seen and "cornet fly plan" in seen  # the walk works
    missing = sorted(name for name, helped in seen.items() if not helped)
    assert missing == [], missing


def test_the_parser_imports_nothing_of_the_simulation():
    """`cornet --help` and a refused flag answer at once: building the parser loads neither
    numpy nor the simulation (a fresh interpreter, as a user runs it)."""
    probe = ("import sys, gateway.cli; gateway.cli.build_parser(); "
             "print(sorted(m for m in ('numpy', 'pybullet', 'numba', 'netsim', 'vehicles') "
             "if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                         cwd=ROOT, check=True).stdout
    assert out.strip() == "[]"
