"""The `isoscope` command forked from a warm interpreter: the mechanism behind `command.run_isoscope`.

A server process imports, once, what every command imports before it reads its arguments; each
`Forked` run is a child of it that takes the caller's environment, folder and files, so a test pays
for the command's work and not for the interpreter's start (0.3-0.8 CPU s a command).  Its peak RSS is
the kernel's high-water mark of its own memory (VmHWM), which clear_refs after the fork starts afresh.
(wait4's ru_maxrss would not do: Linux carries the pre-exec high-water mark into it, so a child of a big
pytest process starts at pytest's size.)  Tests that signal a running command use `Forked` directly;
everything else goes through support.command.
"""
from __future__ import annotations

import atexit
import json
import os
import subprocess
import sys
import threading

HARD_STOP_SECONDS = 120
"""A command still running after this long is killed (and its test fails)."""
# Interrupt tests kill real commands at seeded random moments; each kill costs a command's start.  CI runs
# a few per path; ISOSCOPE_STRESS=N multiplies them (N=3 is what they were first run with).
STRESS = max(1, int(os.environ.get("ISOSCOPE_STRESS", "1") or "1"))


# `python -m isoscope ARGS`, which on its way out (sys.exit, as the command ends) writes its own
# VmHWM to the file named by the environment. The command itself is unchanged.
_WRITE_PEAK = """
def write_peak(path):
    with open("/proc/self/status") as status, open(path, "w") as out:
        out.write(next(line.split()[1] for line in status if line.startswith("VmHWM:")))
"""
_WRAPPER = _WRITE_PEAK + """
import atexit, os, runpy, sys
atexit.register(write_peak, os.environ.pop("ISOSCOPE_TEST_PEAK_FILE"))
sys.argv[0] = "isoscope"
runpy.run_module("isoscope", run_name="__main__", alter_sys=True)
"""

# The same command in a process forked from a warm one. The server imports, once, what every command
# imports before it reads its arguments (and numba's typing registries, which its first kernel call
# loads: 0.3 s); it starts no thread and makes no GL context, so forking it is safe. Each request forks a
# child that takes the caller's environment, folder and files for stdin (/dev/null), stdout and stderr,
# resets its peak RSS to what it holds now (clear_refs 5), and runs the command as the wrapper above
# does, exiting through the interpreter as the command does. A command's own start (the interpreter, the
# imports: 0.3-0.8 CPU s) is what this spares; its peak is measured from the warm start, as the fresh
# one's is from after its imports (the baseline is measured the same way).
_SERVER = _WRITE_PEAK + """
import atexit, json, os, runpy, signal, sys, threading, traceback
import numpy
import isoscope, isoscope.cli.main, isoscope.api, isoscope.io.export, isoscope.cpu.compiled  # noqa: E401
for optional in ("trimesh", "PIL.Image", "pydicom", "nibabel", "tifffile", "nrrd", "scipy.ndimage"):
    try:
        __import__(optional)
    except ImportError:
        pass
from numba.core.registry import cpu_target
cpu_target.target_context.refresh()

def _child(job):
    for fd, path, flags in ((0, os.devnull, os.O_RDONLY), (1, job["out"], os.O_WRONLY), (2, job["err"], os.O_WRONLY)):
        opened = os.open(path, flags)
        os.dup2(opened, fd)
        os.close(opened)
    os.chdir(job["cwd"])
    os.environ.clear()
    os.environ.update(job["env"])
    with open("/proc/self/clear_refs", "w") as refs:
        refs.write("5")

    atexit.register(write_peak, job["peak"])
    sys.argv = ["isoscope", *job["args"]]
    code, killed_by = 0, None
    try:
        runpy.run_module("isoscope", run_name="__main__", alter_sys=True)
    except SystemExit as exc:
        code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
        if isinstance(exc.code, str):
            print(exc.code, file=sys.stderr)
    except KeyboardInterrupt:   # as the interpreter ends on one: a traceback, then killed by SIGINT
        traceback.print_exc()
        killed_by = signal.SIGINT
    except BaseException:
        traceback.print_exc()
        code = 1
    # The interpreter's own way out would tear down every module the server imported (0.3 s and more);
    # the command's exit handlers run, its output is flushed, and the process ends as the command did.
    threading._shutdown()
    atexit._run_exitfuncs()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except Exception:
            pass
    if killed_by is not None:
        signal.signal(killed_by, signal.SIG_DFL)
        os.kill(os.getpid(), killed_by)
    os._exit(code)

requests = os.fdopen(os.dup(0), "r")
replies = os.fdopen(os.dup(1), "w")
for line in iter(requests.readline, ""):
    job = json.loads(line)
    pid = os.fork()
    if pid == 0:
        requests.close()
        replies.close()
        _child(job)
    replies.write(json.dumps(pid) + "\\n")
    replies.flush()
    _, status = os.waitpid(pid, 0)
    replies.write(json.dumps(os.waitstatus_to_exitcode(status)) + "\\n")
    replies.flush()
"""

_server = None            # the warm process of this test process, started by the first forked run
_server_lock = threading.Lock()


class Forked:
    """A command running in a child of the warm server (one at a time per test process): its `pid`, to
    signal it; `wait()` gives its exit status (negative: the signal that ended it)."""

    def __init__(self, args, cwd=None, out: str = os.devnull, err: str = os.devnull, peak_file=os.devnull):
        global _server
        _server_lock.acquire()
        try:
            if _server is None or _server.poll() is not None:
                _server = subprocess.Popen([sys.executable, "-c", _SERVER], stdin=subprocess.PIPE,
                                           stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
                atexit.register(_server.kill)
            self._server, self.args = _server, [str(a) for a in args]
            self._server.stdin.write(json.dumps({"args": self.args, "env": dict(os.environ),
                                                 "cwd": str(cwd or os.getcwd()), "out": str(out), "err": str(err),
                                                 "peak": str(peak_file)}) + "\n")
            self._server.stdin.flush()
            self.pid = json.loads(self._server.stdout.readline())
        except BaseException:
            _server_lock.release()
            raise
        self.returncode = None

    def running(self) -> bool:
        """Whether the command has not ended yet (its child is neither gone nor a zombie)."""
        try:
            with open(f"/proc/{self.pid}/stat") as stat:
                return stat.read().rsplit(")", 1)[1].split()[0] != "Z"
        except OSError:
            return False

    def send_signal(self, signum: int) -> None:
        if self.returncode is None:
            try:
                os.kill(self.pid, signum)
            except ProcessLookupError:   # it ended, and the server has already reaped it
                pass

    def wait(self, timeout: float = HARD_STOP_SECONDS) -> int:
        if self.returncode is not None:
            return self.returncode
        killer = threading.Timer(timeout, os.kill, (self.pid, 9))
        killer.start()
        try:
            reply = self._server.stdout.readline()
        finally:
            killer.cancel()
            _server_lock.release()
        if not reply:
            raise AssertionError(f"the command server ended while running isoscope {' '.join(self.args)}")
        self.returncode = json.loads(reply)
        return self.returncode


def fresh_process(args, env: dict, cwd, out, err, peak_file, timeout: float = HARD_STOP_SECONDS) -> int:
    """`python -m isoscope ARGS` in a new interpreter with `env` (for a test whose environment the imports
    must see), writing to the files `out` and `err` and its peak RSS to `peak_file`; its exit status."""
    process = subprocess.Popen([sys.executable, "-c", _WRAPPER, *map(str, args)], stdout=out, stderr=err,
                               stdin=subprocess.DEVNULL, text=True, cwd=cwd,
                               env={**env, "ISOSCOPE_TEST_PEAK_FILE": str(peak_file)})
    killer = threading.Timer(timeout, process.kill)
    killer.start()
    try:
        return process.wait()
    finally:
        killer.cancel()
