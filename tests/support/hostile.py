"""Run the `isoscope` command on hostile input as a user would, and hold it to the promise for bad input.

The promise (README, "Bad input"): exit 2 and one line on stderr with nothing before it, within a few
seconds, and under 200 MB of resident memory beyond what the command needs to start and refuse a
missing file. Each run is a real subprocess; its peak RSS is the kernel's high-water mark of its
own memory (VmHWM), which exec starts afresh. (wait4's ru_maxrss would not do: Linux carries the
pre-exec high-water mark into it, so a child of a big pytest process starts at pytest's size.)
"""
from __future__ import annotations

import functools
import os
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass
from pathlib import Path

EXTRA_RSS_MB = 200
# Interrupt tests kill real commands at seeded random moments; each kill costs a command's start.  CI runs
# a few per path; ISOSCOPE_STRESS=N multiplies them (N=3 is what they were first run with).
STRESS = max(1, int(os.environ.get("ISOSCOPE_STRESS", "1") or "1"))
HARD_STOP_SECONDS = 120


@dataclass
class Run:
    returncode: int
    stdout: str
    stderr: str
    seconds: float
    peak_rss_mb: float


# `python -m isoscope ARGS`, which on its way out (sys.exit, as the command ends) writes its own
# VmHWM to the file named by the environment. The command itself is unchanged.
_WRAPPER = """
import atexit, os, runpy, sys
def _peak(path=os.environ.pop("ISOSCOPE_TEST_PEAK_FILE")):
    with open("/proc/self/status") as status, open(path, "w") as out:
        out.write(next(line.split()[1] for line in status if line.startswith("VmHWM:")))
atexit.register(_peak)
sys.argv[0] = "isoscope"
runpy.run_module("isoscope", run_name="__main__", alter_sys=True)
"""


def run_isoscope(*args, timeout: float = HARD_STOP_SECONDS, env: dict | None = None, cwd=None) -> Run:
    """`python -m isoscope ARGS` in a subprocess: its exit status, output, wall time and peak RSS (MB;
    NaN where it ended without exiting: a signal)."""
    with tempfile.TemporaryFile("w+") as out, tempfile.TemporaryFile("w+") as err, \
            tempfile.TemporaryDirectory() as scratch:
        peak_file = Path(scratch) / "peak"
        start = time.monotonic()
        process = subprocess.Popen([sys.executable, "-c", _WRAPPER, *map(str, args)], stdout=out, stderr=err,
                                   stdin=subprocess.DEVNULL, text=True, cwd=cwd,
                                   env={**(os.environ if env is None else env),
                                        "ISOSCOPE_TEST_PEAK_FILE": str(peak_file)})
        killer = threading.Timer(timeout, process.kill)
        killer.start()
        try:
            process.wait()
        finally:
            killer.cancel()
        seconds = time.monotonic() - start
        out.seek(0)
        err.seek(0)
        stdout, stderr = out.read(), err.read()
        peak_mb = int(peak_file.read_text()) / 1024.0 if peak_file.exists() else float("nan")
    if seconds >= timeout:
        raise AssertionError(f"isoscope {' '.join(map(str, args))} ran past {timeout} s; stderr:\n{stderr[-2000:]}")
    return Run(process.returncode, stdout, stderr, seconds, peak_mb)


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
