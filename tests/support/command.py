"""The `isoscope` command as a user runs it (a subprocess), the same command run in this process, and the
one-line refusal it owes bad input."""
from __future__ import annotations

import contextlib
import io
import os
import subprocess
import sys
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def isoscope(*args, env_drop=(), env_add=None, cwd=None):
    env = {k: v for k, v in os.environ.items() if k not in env_drop}
    env.update(env_add or {})
    return subprocess.run([sys.executable, "-m", "isoscope", *map(str, args)], capture_output=True, text=True,
                          env=env, cwd=cwd or REPO, timeout=120)


# Python's own warning filters (no -W, no PYTHONWARNINGS): what the command runs under as a process.
_PYTHON_DEFAULT_FILTERS = (("default", DeprecationWarning, "__main__"), ("ignore", DeprecationWarning, None),
                           ("ignore", PendingDeprecationWarning, None), ("ignore", ImportWarning, None),
                           ("ignore", ResourceWarning, None))


def isoscope_here(*args, cwd=None) -> subprocess.CompletedProcess:
    """`isoscope ARGS` run in this process (`isoscope.cli.main.main`), returned as `isoscope(...)` returns it:
    exit status, stdout and stderr. It skips what a new process pays before the command does anything (the
    interpreter, the imports, a GL context, shader compiles: about 1.3 CPU seconds), so it suits tests of
    what the command does (its files, its messages, its exit status); what only a process shows (signals,
    the environment, a GL version override, chatter written to the file descriptor, bytes to stdout with
    `--out -`, a cluster's worker processes) needs `isoscope`. A warning the command lets through is on
    stderr, as the process would print it."""
    from isoscope.cli.main import main
    argv = [str(arg) for arg in args]
    out, err = io.StringIO(), io.StringIO()
    before = os.getcwd()
    with warnings.catch_warnings(record=True) as caught, contextlib.redirect_stdout(out), \
            contextlib.redirect_stderr(err):
        warnings.resetwarnings()
        for action, category, module in reversed(_PYTHON_DEFAULT_FILTERS):
            warnings.filterwarnings(action, category=category, module=module or "")
        os.chdir(cwd or REPO)
        try:
            status = main(argv)
        except SystemExit as exc:   # argparse: --help (0) and usage errors (2)
            status = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
            if isinstance(exc.code, str):
                print(exc.code, file=sys.stderr)
        finally:
            os.chdir(before)
    shown = "".join(warnings.formatwarning(w.message, w.category, w.filename, w.lineno, w.line) for w in caught)
    return subprocess.CompletedProcess(["isoscope", *argv], status, out.getvalue(), err.getvalue() + shown)


def assert_one_line_error(result, *words):
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    for word in words:
        assert word in lines[0]


NO_GL = {"__EGL_VENDOR_LIBRARY_FILENAMES": "/nonexistent.json"}   # with env_drop=("DISPLAY",): a machine with no GL
