"""`cornet --help` and every subcommand's help say what each option and argument is for."""

import argparse

from gateway.cli import build_parser


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
