"""``cornet``'s entry point: gateway/cli.py behind a guard for Ctrl-C.

Importing the daemon takes most of a second, and a Ctrl-C in that time (or in anything before
a command installs its own handlers) would otherwise end the program with a KeyboardInterrupt
traceback. This module imports nothing else until it runs, so a Ctrl-C then ends ``cornet`` as
a shell reports an interrupted command: exit code 130 (128 + SIGINT) and one line.
"""

from __future__ import annotations

import sys

INTERRUPTED = 130  # 128 + SIGINT


def main(argv: list[str] | None = None) -> int:
    try:
        from gateway.cli import main as cli_main

        return cli_main(argv)
    except KeyboardInterrupt:
        print("cornet: interrupted", file=sys.stderr)
        return INTERRUPTED


if __name__ == "__main__":
    sys.exit(main())
