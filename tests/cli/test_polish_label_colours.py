"""export --labels --one-file colours each label's vertices as its label names file says (as the viewer
draws it), and movie --labels draws the labels as render --labels does."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh
from PIL import Image
from support.command import assert_one_line_error
from support.command import isoscope_here as run

NAMES = """\
# IDX   -R-  -G-  -B-  -A--  VIS MSH  LABEL
    1   250   20   20     1    1   1  "red block"
    3    20  200   40     1    1   1  "green block"
"""


@pytest.fixture
def seg(tmp_path):
    volume = np.zeros((24, 24, 24), np.uint8)
    volume[3:10, 3:20, 3:20], volume[12:20, 5:12, 5:12], volume[12:20, 14:20, 14:20] = 1, 2, 3
    np.save(tmp_path / "seg.npy", volume)
    (tmp_path / "names.txt").write_text(NAMES)
    return tmp_path / "seg.npy"


def _colours_by_part(path):
    """{vertex count of a connected part: its one RGB} from the PLY, read by trimesh."""
    mesh = trimesh.load(path, process=False)
    found = {}
    for part in mesh.split(only_watertight=False):
        colours = np.unique(part.visual.vertex_colors[:, :3], axis=0)
        assert len(colours) == 1
        found[len(part.vertices)] = tuple(int(c) for c in colours[0])
    return mesh, found


def test_one_file_colours_follow_the_names_file(seg, tmp_path):
    result = run("export", seg, "--labels", "--one-file", "--label-names", tmp_path / "names.txt",
                 "--out", tmp_path / "named.ply")
    assert result.returncode == 0, result.stderr
    plain = run("export", seg, "--labels", "--one-file", "--out", tmp_path / "plain.ply")
    assert plain.returncode == 0, plain.stderr
    named, _ = _colours_by_part(tmp_path / "named.ply")
    colours = {tuple(int(c) for c in rgb) for rgb in np.unique(named.visual.vertex_colors[:, :3], axis=0)}
    assert (250, 20, 20) in colours and (20, 200, 40) in colours and len(colours) == 3
    # Label 1 is the big slab (x 3..9): its vertices are red; label 3's (x 12..19, y 14..19) are green.
    verts, rgb = named.vertices, named.visual.vertex_colors[:, :3]
    assert (rgb[verts[:, 0] < 10.5] == (250, 20, 20)).all()
    assert (rgb[(verts[:, 0] > 11) & (verts[:, 1] > 13)] == (20, 200, 40)).all()
    # Label 2, not listed, keeps the default palette's colour, the one the plain export gives it.
    plain_mesh = trimesh.load(tmp_path / "plain.ply", process=False)
    two = (verts[:, 0] > 11) & (verts[:, 1] < 12.5)
    plain_two = (plain_mesh.vertices[:, 0] > 11) & (plain_mesh.vertices[:, 1] < 12.5)
    assert np.array_equal(rgb[two], plain_mesh.visual.vertex_colors[plain_two, :3])
    assert np.allclose(named.vertices, plain_mesh.vertices)


def test_the_names_file_beside_the_segmentation_colours_it_too(seg, tmp_path):
    (tmp_path / "names.txt").rename(tmp_path / "seg.txt")
    assert run("export", seg, "--labels", "--one-file", "--out", tmp_path / "beside.ply").returncode == 0
    rgb = trimesh.load(tmp_path / "beside.ply", process=False).visual.vertex_colors[:, :3]
    assert ((rgb == (250, 20, 20)).all(axis=1)).any()


def test_label_names_without_its_place_is_one_line(seg, tmp_path):
    assert_one_line_error(run("export", seg, "--label-names", tmp_path / "names.txt", "--out", tmp_path / "x.ply"),
                          "--label-names needs --labels")
    assert_one_line_error(run("export", seg, "--labels", "--label-names", tmp_path / "names.txt",
                              "--out", tmp_path / "x.ply"), "add --one-file")
    assert_one_line_error(run("movie", seg, "--label-names", tmp_path / "names.txt", "--out", tmp_path / "m.gif"),
                          "--label-names needs --labels")
    assert_one_line_error(run("movie", seg, "--labels", "--sweep", "0:1", "--out", tmp_path / "m.gif"),
                          "--sweep does not apply with --labels")


@pytest.mark.gl
def test_movie_labels_frame_is_renders_picture(seg, tmp_path):
    common = ("--labels", "--label-names", tmp_path / "names.txt", "--clip", "y=12", "--size", "200x150",
              "--azimuth", "30", "--elevation", "20")
    result = run("movie", seg, *common, "--turntable", "4", "--out", f"{tmp_path / 'frames'}/")
    assert result.returncode == 0, result.stderr
    assert run("render", seg, *common, "--out", tmp_path / "still.png").returncode == 0
    frames = sorted((tmp_path / "frames").glob("*.png"))
    assert len(frames) == 4
    first = np.asarray(Image.open(frames[0]).convert("RGB"))
    assert np.array_equal(first, np.asarray(Image.open(tmp_path / "still.png").convert("RGB")))
    red = (first[..., 0].astype(int) > 2 * first[..., 2]) & (first[..., 0] > 80)
    assert red.sum() > 300   # label 1 in the names file's red
    assert not np.array_equal(first, np.asarray(Image.open(frames[2]).convert("RGB")))
