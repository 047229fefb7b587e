"""Running the `isoscope` command in tests: the one place that says how, and which way suits what.

=======================  =====================================================================  ==========
runner                   what it is, and what it suits                                          start cost
=======================  =====================================================================  ==========
`isoscope_here`          the command's `main()` in this process, as a CompletedProcess; for     none
                         what the command does: its files, messages and exit status
`isoscope`               ``python -m isoscope`` in a new interpreter, as a user runs it; for    ~1.3 CPU s
                         what only a process shows: the environment (`env_drop`, `env_add`,
                         `NO_GL`), signals, a GL version override, output on the descriptor
`isoscope_batch`         several commands, each as `isoscope_here` runs it, in one new          one start
                         process: for commands that need a process but not one each
`run_isoscope`           a process forked from a warm server (support.forked), or a new         a fork
                         interpreter with `env`; a `Run` with wall time and peak RSS: for the
                         promise to bad input (README, "Bad input")
=======================  =====================================================================  ==========

What a result must be: `succeeded_here` (an `isoscope_here` run: exit 0, nothing on stderr),
`succeeded` and `refused` (a `run_isoscope` run: exit 0 and a quiet stderr; or exit 2 with one line on
stderr naming the words, within seconds and under `EXTRA_RSS_MB` of memory beyond the command's
baseline), `assert_one_line_error` (any result: exit 2 and one line).  Tests that signal a running
command use support.forked.Forked.
"""
from __future__ import annotations

import contextlib
import functools
import io
import json
import os
import subprocess
import sys
import tempfile
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

from support.forked import HARD_STOP_SECONDS, Forked, fresh_process

EXTRA_RSS_MB = 200

REPO = Path(__file__).resolve().parents[2]


def _environment(env_drop=(), env_add=None) -> dict:
    """This process's environment without `env_drop` and with `env_add`."""
    env = {k: v for k, v in os.environ.items() if k not in env_drop}
    env.update(env_add or {})
    return env


def isoscope(*args, env_drop=(), env_add=None, cwd=None) -> subprocess.CompletedProcess:
    """`python -m isoscope ARGS` in a new interpreter, in this environment less `env_drop` plus `env_add`."""
    return subprocess.run([sys.executable, "-m", "isoscope", *map(str, args)], capture_output=True, text=True,
                          env=_environment(env_drop, env_add), cwd=cwd or REPO, timeout=120)


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
    env = _environment(env_drop, env_add)
    jobs = [[str(arg) for arg in args] for args in commands]
    child = subprocess.run([sys.executable, "-c", _BATCH, str(Path(__file__).resolve().parents[1]),
                            json.dumps(jobs), str(cwd or REPO)], capture_output=True, text=True, env=env,
                           cwd=cwd or REPO, timeout=300)
    results = [json.loads(line) for line in child.stdout.splitlines() if line.startswith("[")]
    assert len(results) == len(jobs), f"the batch stopped after {len(results)} of {len(jobs)}:\n{child.stderr}"
    return [subprocess.CompletedProcess(["isoscope", *args], status, out, err)
            for args, (status, out, err) in zip(jobs, results)]


def assert_one_line_error(result, *words):
    """Exit 2, no traceback, one line on stderr naming every word."""
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    for word in words:
        assert word in lines[0]


# With env_drop=("DISPLAY",): a machine with no GL. No EGL vendor, and no libGL for glcontext's fallback, which
# opens X display :0.0 whatever DISPLAY says (a desktop or a stray Xvfb there would give it GL).
NO_GL = {"__EGL_VENDOR_LIBRARY_FILENAMES": "/nonexistent.json", "GLCONTEXT_LINUX_LIBGL": "/nonexistent/libGL.so.1"}


# -- forked runs: wall time and peak memory --------------------------------------------------------

@dataclass
class Run:
    returncode: int
    stdout: str
    stderr: str
    seconds: float
    peak_rss_mb: float


def run_isoscope(*args, timeout: float = HARD_STOP_SECONDS, env: dict | None = None, cwd=None) -> Run:
    """`python -m isoscope ARGS` in a process of its own: its exit status, output, wall time and peak RSS (MB;
    NaN where it ended without exiting: a signal). Forked from the warm server unless `env` (a different
    environment from the start, which imports may read) is given: then a new interpreter."""
    with tempfile.NamedTemporaryFile("w+") as out, tempfile.NamedTemporaryFile("w+") as err, \
            tempfile.TemporaryDirectory() as scratch:
        peak_file = Path(scratch) / "peak"
        start = time.monotonic()
        if env is not None:
            returncode = fresh_process(args, env, cwd, out, err, peak_file, timeout)
        else:
            returncode = Forked(args, cwd, out.name, err.name, peak_file).wait(timeout)
        seconds = time.monotonic() - start
        out.seek(0)
        err.seek(0)
        stdout, stderr = out.read(), err.read()
        peak_mb = int(peak_file.read_text()) / 1024.0 if peak_file.exists() else float("nan")
    if seconds >= timeout:
        raise AssertionError(f"isoscope {' '.join(map(str, args))} ran past {timeout} s; stderr:\n{stderr[-2000:]}")
    return Run(returncode, stdout, stderr, seconds, peak_mb)


@functools.cache
def baseline_rss_mb() -> float:
    """Peak RSS of the command refusing a missing file: what it needs to start, import and say no."""
    return run_isoscope("/nonexistent/volume.nii").peak_rss_mb


def refused(*args, words=(), seconds: float = 10.0, extra_rss_mb: float = EXTRA_RSS_MB, **kwargs) -> str:
    """Run the command; expect exit 2 and exactly one stderr line naming every word, quickly, in little memory.

    Returns that line."""
    run = run_isoscope(*args, **kwargs)
    lines = run.stderr.splitlines()
    assert run.returncode == 2, f"exit {run.returncode}, stderr:\n{run.stderr[-3000:]}"
    assert len(lines) == 1, f"expected one line on stderr, got {len(lines)}:\n{run.stderr[-3000:]}"
    line = lines[0]
    assert line.startswith("isoscope: "), line
    for word in words:
        assert word.lower() in line.lower(), line
    assert run.seconds < seconds, f"took {run.seconds:.1f} s: {line}"
    extra = run.peak_rss_mb - baseline_rss_mb()
    assert extra < extra_rss_mb, f"peak RSS {run.peak_rss_mb:.0f} MB, {extra:.0f} MB over the baseline: {line}"
    return line


def succeeded(*args, **kwargs) -> Run:
    """Run the command; expect exit 0 and nothing on stderr."""
    run = run_isoscope(*args, **kwargs)
    assert run.returncode == 0, f"exit {run.returncode}, stderr:\n{run.stderr[-3000:]}"
    assert run.stderr == "", run.stderr
    return run
