"""The `isoscope` command's entry point: a Ctrl-C at any moment, also while the command's modules import
or its arguments are read (before `cli.main`'s own handling is in place), ends it with exit 130 and no
traceback."""
from __future__ import annotations


def main() -> int:
    try:
        from .cli import main as run
        return run()
    except KeyboardInterrupt:
        return 130
