"""The `isoscope` command as a user runs it (a subprocess), and the one-line refusal it owes bad input."""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def isoscope(*args, env_drop=(), env_add=None, cwd=None):
    env = {k: v for k, v in os.environ.items() if k not in env_drop}
    env.update(env_add or {})
    return subprocess.run([sys.executable, "-m", "isoscope", *map(str, args)], capture_output=True, text=True,
                          env=env, cwd=cwd or REPO, timeout=120)


def assert_one_line_error(result, *words):
    assert result.returncode == 2, result.stderr
    assert "Traceback" not in result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    for word in words:
        assert word in lines[0]


NO_GL = {"__EGL_VENDOR_LIBRARY_FILENAMES": "/nonexistent.json"}   # with env_drop=("DISPLAY",): a machine with no GL
