"""The `isoscope` command as a user runs it (a subprocess), the same command run in this process, and the
one-line refusal it owes bad input."""
from __future__ import annotations

import contextlib
import io
import json
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


def succeeded_here(*args, cwd=None) -> subprocess.CompletedProcess:
    """`isoscope_here`, which must exit 0 with nothing on stderr."""
    done = isoscope_here(*args, cwd=cwd)
    assert done.returncode == 0 and done.stderr == "", done.stderr
    return done


# Each command of a batch run by `isoscope_here` in one process; one JSON line each: status, stdout, stderr.
_BATCH = """
import json, sys
sys.path.insert(0, sys.argv[1])
from support.command import isoscope_here
for args in json.loads(sys.argv[2]):
    done = isoscope_here(*args, cwd=sys.argv[3])
    print("\\n" + json.dumps([done.returncode, done.stdout, done.stderr]), flush=True)
"""


def isoscope_batch(*commands, env_drop=(), env_add=None, cwd=None) -> list[subprocess.CompletedProcess]:
    """Each of `commands` (argument lists) run one after another by one process of its own, in the
    environment `isoscope` would give it, each as `isoscope_here` runs it: for commands that need a process
    (a display, a GL version override, windows) but not one process each. Their results, in order."""
    env = {k: v for k, v in os.environ.items() if k not in env_drop}
    env.update(env_add or {})
    jobs = [[str(arg) for arg in args] for args in commands]
    child = subprocess.run([sys.executable, "-c", _BATCH, str(Path(__file__).resolve().parents[1]),
                            json.dumps(jobs), str(cwd or REPO)], capture_output=True, text=True, env=env,
                           cwd=cwd or REPO, timeout=300)
    results = [json.loads(line) for line in child.stdout.splitlines() if line.startswith("[")]
    assert len(results) == len(jobs), f"the batch stopped after {len(results)} of {len(jobs)}:\n{child.stderr}"
    return [subprocess.CompletedProcess(["isoscope", *args], status, out, err)
            for args, (status, out, err) in zip(jobs, results)]


def assert_one_line_error(result, *words):
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    for word in words:
        assert word in lines[0]


# With env_drop=("DISPLAY",): a machine with no GL. No EGL vendor, and no libGL for glcontext's fallback, which
# opens X display :0.0 whatever DISPLAY says (a desktop or a stray Xvfb there would give it GL).
NO_GL = {"__EGL_VENDOR_LIBRARY_FILENAMES": "/nonexistent.json", "GLCONTEXT_LINUX_LIBGL": "/nonexistent/libGL.so.1"}
