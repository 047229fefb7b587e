"""Every flag's value, as hypothesis writes them (issue 35): parsed, or refused in one line with exit 2;
never a traceback, never a hang.  The numbers that drive work (smoothing, frames, sizes, chunks) are
then run through the command on a small volume: the work is done or refused in one line, in seconds."""
from __future__ import annotations

import contextlib
import io

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from support.command import isoscope_here

from isoscope.cli.arguments import command_parser, viewer_parser
from isoscope.cli.measure import measure_parser
from isoscope.cli.movie import movie_parser

PARSERS = {"viewer": (viewer_parser, []), "render": (lambda: command_parser("render"), ["sphere", "--out", "x.png"]),
           "export": (lambda: command_parser("export"), ["sphere", "--out", "x.ply"]),
           "measure": (measure_parser, ["sphere"]), "movie": (movie_parser, ["sphere", "--out", "x.mp4"])}
FLAGS = sorted({(name, action.option_strings[0], action.nargs) for name, (make, _) in PARSERS.items()
                for action in make()._actions if action.option_strings and action.nargs != 0
                and action.option_strings[0] not in ("-h", "--help", "--version")})
WORDS = st.one_of(st.text(max_size=12), st.integers(-10**30, 10**30).map(str),
                  st.floats(allow_nan=True, allow_infinity=True).map(repr),
                  st.sampled_from(["0", "-1", "1e308", "nan", "inf", "-inf", "0x0", "99999999x1", "1:2", "a=b",
                                   "x=-5", "\x1b[2J", "-", "--", "", " ", "1e-320", "9" * 40]))


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(flag=st.sampled_from(FLAGS), words=st.lists(WORDS, min_size=3, max_size=3))
def test_every_flag_parses_or_refuses_in_one_line(flag, words):
    name, option, nargs = flag
    make, positional = PARSERS[name]
    values = words[: nargs if isinstance(nargs, int) else 1]
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        try:
            make().parse_args([*positional, f"{option}={values[0]}" if len(values) == 1 else option,
                               *(values if len(values) > 1 else [])])
        except SystemExit as exc:
            assert exc.code == 2, (option, values, err.getvalue())
            lines = err.getvalue().strip().splitlines()
            assert len(lines) == 1 and lines[0].startswith("isoscope: error:"), (option, values, err.getvalue())
            assert "\x1b" not in lines[0]


@pytest.fixture(scope="module")
def small(tmp_path_factory):
    path = tmp_path_factory.mktemp("small") / "ball.npy"
    axis = np.linspace(-1, 1, 12, dtype=np.float32)
    x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
    np.save(path, 0.6 - np.sqrt(x * x + y * y + z * z))
    return path


@pytest.mark.parametrize("args", [
    ("export", "--smooth", "1000000000"), ("export", "--smooth", "-1"), ("export", "--chunk", "0"),
    ("export", "--chunk", "-5"), ("export", "--chunk", "99999999999"), ("export", "--decimate", "nan"),
    ("export", "--decimate", "1e308"), ("export", "--iso", "nan"), ("export", "--iso", "inf"),
    ("export", "--workers", "0"), ("export", "--resolution", "0"), ("export", "--spacing", "0", "1", "1"),
    ("export", "--spacing", "nan", "1", "1"), ("export", "--time", "99999999999"), ("export", "--max-labels", "0"),
    ("measure", "--iso", "-1e308"), ("measure", "--time", "5:2"), ("export", "--sharp", "180"),
])
def test_work_numbers_are_done_or_refused_in_one_line(small, tmp_path, args):
    command, *rest = args
    out = ["--out", tmp_path / "m.ply"] if command == "export" else []
    done = isoscope_here(command, small, *rest, *out)
    assert done.returncode in (0, 2), done.stderr
    if done.returncode == 2:
        lines = done.stderr.strip().splitlines()
        assert len(lines) == 1 and "Traceback" not in done.stderr, done.stderr
        assert not (tmp_path / "m.ply").exists()


@pytest.fixture(scope="module")
def segmentation(tmp_path_factory):
    path = tmp_path_factory.mktemp("seg") / "seg.npy"
    seg = np.zeros((16, 16, 16), np.uint8)
    seg[3:8, 3:8, 3:8], seg[9:14, 9:14, 9:14] = 1, 2
    np.save(path, seg)
    return path


def test_label_tables_that_are_no_files_or_too_big_are_refused_at_once(segmentation, tmp_path):
    """--label-names /dev/zero grew past 4 GB, a FIFO blocked forever, a 100 MB table took 18 s."""
    import os
    import time
    fifo = tmp_path / "names.fifo"
    os.mkfifo(fifo)
    big = tmp_path / "big.txt"
    with open(big, "wb") as out:
        out.truncate(100 << 20)   # sparse: 100 MB that takes no disk
    start = time.monotonic()
    for names, words in (("/dev/zero", "a device"), (fifo, "a named pipe"), (big, "104,857,600 bytes")):
        done = isoscope_here("measure", segmentation, "--labels", "--label-names", names)
        assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1, done.stderr
        assert words in done.stderr and "label names file" in done.stderr
    assert time.monotonic() - start < 10


@pytest.mark.gl
def test_label_tables_from_python_and_scenes_go_through_the_opener(segmentation, tmp_path):
    import json

    import isoscope
    with pytest.raises(isoscope.IsoscopeError, match="a device"):
        isoscope.render(np.load(segmentation), labels=True, label_names="/dev/zero", size=(64, 64))
    saved = isoscope_here("render", segmentation, "--labels", "--out", tmp_path / "s.png",
                          "--save-scene", tmp_path / "s.json")
    assert saved.returncode == 0, saved.stderr
    scene = json.loads((tmp_path / "s.json").read_text())
    scene["labels"]["names"] = "/dev/zero"
    (tmp_path / "s.json").write_text(json.dumps(scene))
    done = isoscope_here("render", tmp_path / "s.json", "--out", tmp_path / "t.png")
    assert done.returncode == 2 and "a device" in done.stderr and len(done.stderr.strip().splitlines()) == 1
