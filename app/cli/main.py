"""The `isoscope` command: the viewer window, headless renders, mesh export, the list of built-ins.

Bad input ends with one line on stderr naming the problem and the fix, and
exit status 2; no traceback reaches the user.
"""
from __future__ import annotations

import errno
import os
import sys

from ..volumes import DEFAULT_VOLUME, VolumeError
from .arguments import COMMANDS, command_parser, viewer_parser
from .common import EXIT_BAD_INPUT, EXIT_BROKEN_PIPE, EXIT_CLUSTER_FAILED, EXIT_NO_GL
from .export import run_export
from .render import run_render, run_viewer


def run_volumes(args) -> int:
    """``isoscope volumes``: print the built-in volumes, one a line, marking the default; exit status 0."""
    from ..volumes import describe_builtins
    rows = describe_builtins()
    width = max(len(name) for name, _ in rows)
    for name, description in rows:
        marker = " (default)" if name == DEFAULT_VOLUME else ""
        print(f"{name:<{width}}  {description}{marker}")
    return 0


RUNNERS = {"render": run_render, "export": run_export, "volumes": run_volumes}


def _error(text: str) -> None:
    """The one line of a refusal, on stderr: control characters escaped, so that a path or a name carrying
    ESC or BEL (from a file name, a scene, a label table) cannot clear the terminal or retitle it, and a
    newline in one cannot split the line."""
    from ..core.opener import shown
    print(f"isoscope: error: {shown(text)}", file=sys.stderr)


def main(argv: list[str] | None = None) -> int:
    """Run the command `argv` (default: the command line) and return its exit status: 0; a refusal's status
    after its one line on stderr (bad input, no OpenGL, a failed cluster or a full disk); quietly on a broken
    pipe; 130 on Ctrl-C."""
    argv = sys.argv[1:] if argv is None else list(argv)
    if argv and argv[0] == "measure":
        from .measure import measure_parser, run_measure
        args, runner = measure_parser().parse_args(argv[1:]), run_measure
    elif argv and argv[0] == "movie":
        from .movie import movie_parser, run_movie
        args, runner = movie_parser().parse_args(argv[1:]), run_movie
    elif argv and argv[0] in COMMANDS:
        command, rest = argv[0], argv[1:]
        args, runner = command_parser(command).parse_args(rest), RUNNERS[command]
    else:
        args, runner = viewer_parser().parse_args(argv), run_viewer
    from ..big.cluster import ClusterError
    from ..core.budget import MemoryBudget, using_budget
    from ..gpu.context import GLUnavailable
    given = getattr(args, "memory_budget", None)
    try:
        with using_budget(None if given is None else MemoryBudget(given, "--memory-budget")):
            return runner(args)
    except ClusterError as exc:
        _error(str(exc))
        return exc.exit_status  # 2 for an address that is no dask scheduler: the input
    except (VolumeError, ValueError) as exc:
        # VolumeError and the extractor's ValueErrors carry one-line, user-facing messages.
        _error(str(exc))
        return EXIT_BAD_INPUT
    except BrokenPipeError:
        # `isoscope measure --json | head`: the reader left; stop quietly, as Unix tools do on SIGPIPE
        # (stdout pointed at /dev/null so that Python's exit flush does not complain again).
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return EXIT_BROKEN_PIPE
    except OSError as exc:
        if exc.errno in (errno.ENOSPC, errno.EFBIG, errno.EDQUOT):  # the disk (or a size limit) is full
            _error(f"{exc.strerror}: the output did not fit, and no partial file was left; free disk space or "
                   "write it elsewhere")
            return EXIT_CLUSTER_FAILED
        _error(f"{exc.strerror or exc}: {exc.filename or ''}; check the path and its permissions")
        return EXIT_BAD_INPUT
    except GLUnavailable as exc:
        print(f"isoscope: {exc}", file=sys.stderr)
        return EXIT_NO_GL
    except KeyboardInterrupt:
        return 130
