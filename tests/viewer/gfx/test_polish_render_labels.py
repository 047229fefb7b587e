"""isoscope.render(labels=True) draws through the viewer's scene as `isoscope render --labels` does: the same
picture, with the clip, the label names file's colours and opacities, and the orientation letters."""
from __future__ import annotations

import numpy as np
import pytest
from PIL import Image
from support.command import isoscope_here as run

import isoscope

pytestmark = pytest.mark.gl

NAMES = """\
# IDX   -R-  -G-  -B-  -A--  VIS MSH  LABEL
    1   250   20   20     1    1   1  "red block"
    2    20   20  250   0.5    1   1  "blue block"
"""


def segmentation() -> np.ndarray:
    seg = np.zeros((32, 32, 32), np.uint8)
    seg[4:20, 4:28, 4:28], seg[20:28, 8:24, 8:24] = 1, 2
    return seg


def test_render_labels_equals_the_commands_png(tmp_path):
    seg = segmentation()
    np.save(tmp_path / "seg.npy", seg)
    (tmp_path / "names.txt").write_text(NAMES)
    result = run("render", tmp_path / "seg.npy", "--labels", "--label-names", tmp_path / "names.txt",
                 "--clip", "y=15:+", "--size", "240x180", "--azimuth", "30", "--elevation", "20",
                 "--out", tmp_path / "cli.png")
    assert result.returncode == 0, result.stderr
    cli = np.asarray(Image.open(tmp_path / "cli.png").convert("RGB"))
    image = isoscope.render(seg, labels=True, label_names=tmp_path / "names.txt", clip=("y", 15), size=(240, 180),
                            azimuth=30, elevation=20)
    assert image.shape == (180, 240, 4)
    assert np.array_equal(image[..., :3], cli)
    # The file's colours: red's hue where label 1 shows; the clip changes the picture.
    red = (image[..., 0].astype(int) > 2 * image[..., 2]) & (image[..., 0] > 80)
    assert red.sum() > 500
    unclipped = isoscope.render(seg, labels=True, label_names=tmp_path / "names.txt", size=(240, 180),
                                azimuth=30, elevation=20)
    assert not np.array_equal(unclipped, image)


def test_render_labels_with_a_level_or_names_without_labels_is_one_line(tmp_path):
    seg = segmentation()
    with pytest.raises(ValueError, match="leave out the level"):
        isoscope.render(seg, 1, labels=True)
    with pytest.raises(ValueError, match="labels=True"):
        isoscope.render(seg, 0.5, label_names=tmp_path / "names.txt")
    with pytest.raises(ValueError, match="axis"):
        isoscope.render(seg, 0.5, clip=("w", 3))


def test_render_letters_and_slices_as_the_command(tmp_path):
    x, y, z = np.mgrid[-1:1:24j, -1:1:24j, -1:1:24j]
    field = (0.6 - np.sqrt(x * x + y * y + z * z)).astype(np.float32)
    np.save(tmp_path / "f.npy", field)
    result = run("render", tmp_path / "f.npy", "--iso", "0", "--slice", "z=12", "--orientation-letters",
                 "--size", "200x150", "--out", tmp_path / "cli.png")
    assert result.returncode == 0, result.stderr
    cli = np.asarray(Image.open(tmp_path / "cli.png").convert("RGB"))
    image = isoscope.render(field, 0.0, slices=[("z", 12)], letters=True, size=(200, 150))
    assert np.array_equal(image[..., :3], cli)
