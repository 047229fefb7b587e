"""Label names files (volumes/label_names.py): ITK-SNAP's label description and 3D Slicer's colour table,
read for names and colours, found beside the segmentation, refused in one line naming the bad line; and
`measure --labels --json` naming each label."""
from __future__ import annotations

import json

import numpy as np
import pytest
from support.command import assert_one_line_error, isoscope_here

from isoscope.volumes import VolumeError
from isoscope.volumes.label_names import beside, read_label_names

# As ITK-SNAP 4 writes it (Segmentation > Export Label Descriptions), header included.
ITKSNAP = """\
################################################
# ITK-SnAP Label Description File
# File format:
# IDX   -R-  -G-  -B-  -A--  VIS MSH  LABEL
# Fields:
#    IDX:   Zero-based index
#    -R-:   Red color component (0..255)
#    -G-:   Green color component (0..255)
#    -B-:   Blue color component (0..255)
#    -A-:   Label transparency (0.00 .. 1.00)
#    VIS:   Label visibility (0 or 1)
#    IDX:   Label mesh visibility (0 or 1)
#  LABEL:   Label description
################################################
    0     0    0    0        0  0  0    "Clear Label"
    1   255    0    0        1  1  1    "Left hippocampus"
    2     0  255    0      0.5  1  1    "Right hippocampus"
   12     0    0  255        1  0  1    "Hidden structure"
"""

# As 3D Slicer saves a colour table (.ctbl), and FreeSurfer's LUT (alpha 0 for every label).
SLICER = """\
# Color table file /tmp/GenericColors.ctbl
# 3 values
0 background 0 0 0 0
1 tissue 128 174 128 255
3 Left-Cerebral-White-Matter 245 245 245 0
"""


def test_an_itksnap_label_description_gives_names_colours_opacity_and_visibility(tmp_path):
    path = tmp_path / "label_description.txt"
    path.write_text(ITKSNAP)
    names = read_label_names(path)
    assert sorted(names) == [0, 1, 2, 12]
    assert names[1].name == "Left hippocampus" and names[1].color == (1.0, 0.0, 0.0)
    assert names[2].name == "Right hippocampus" and names[2].opacity == 0.5 and names[2].visible
    assert names[12].color == (0.0, 0.0, 1.0) and not names[12].visible   # VIS 0


def test_a_slicer_colour_table_gives_names_and_colours(tmp_path):
    path = tmp_path / "seg.ctbl"
    path.write_text(SLICER)
    names = read_label_names(path)
    assert names[1].name == "tissue" and names[1].color == (128 / 255, 174 / 255, 128 / 255)
    # FreeSurfer's alpha 0 is not "invisible": its labels are drawn opaque, as Slicer draws them.
    assert names[3].name == "Left-Cerebral-White-Matter" and names[3].opacity == 1.0 and names[3].visible


@pytest.mark.parametrize("text, words", [
    (SLICER.replace("1 tissue 128 174 128 255", "1 tissue 128 174 128"), ["line 4", "5 fields", "index name R G B A"]),
    (SLICER.replace("128 174", "128 300"), ["line 4", "G is 300", "0..255"]),
    (SLICER.replace("1 tissue", "one tissue"), ["line 4", "index is 'one'"]),
    (SLICER + "1 again 1 2 3 255\n", ["line 6", "label 1 is listed twice"]),
    (ITKSNAP.replace('"Left hippocampus"', '"Left hippocampus'), ["line 16", "not closed"]),
    (ITKSNAP.replace("0.5  1  1", "1.5  1  1"), ["line 17", "A is 1.5", "IDX R G B A VIS MSH"]),
    (ITKSNAP.replace("1  0  1", "1  2  1"), ["line 18", "VIS and MSH must be 0 or 1"]),
    ("# nothing but comments\n", ["lists no labels"]),
])
def test_a_malformed_file_is_refused_in_one_line_naming_its_line(tmp_path, text, words):
    path = tmp_path / "names.txt"
    path.write_text(text)
    with pytest.raises(VolumeError) as error:
        read_label_names(path)
    message = str(error.value)
    assert "\n" not in message and message.startswith("names.txt")
    for word in words:
        assert word in message, message


def test_the_file_beside_the_segmentation_is_found_by_its_stem(tmp_path):
    seg = tmp_path / "brain.nii.gz"
    seg.write_bytes(b"")
    assert beside(seg) is None
    (tmp_path / "brain_label_description.txt").write_text(ITKSNAP)
    assert beside(seg) == tmp_path / "brain_label_description.txt"
    (tmp_path / "brain.ctbl").write_text(SLICER)   # a colour table of the same stem comes first
    assert beside(seg) == tmp_path / "brain.ctbl"
    assert beside("sphere") is None   # a built-in: no file, nothing beside it


@pytest.fixture
def segmentation(tmp_path):
    labels = np.zeros((20, 18, 16), np.uint8)
    labels[3:9, 4:14, 4:12] = 1
    labels[9:16, 4:14, 4:12] = 2
    labels[2:5, 2:5, 2:5] = 12
    np.save(tmp_path / "seg.npy", labels)
    (tmp_path / "seg_label_description.txt").write_text(ITKSNAP)
    return tmp_path / "seg.npy"


def test_measure_json_names_each_label(segmentation, tmp_path):
    result = isoscope_here("measure", segmentation, "--labels", "--json")
    assert result.returncode == 0, result.stderr
    records = json.loads(result.stdout)
    assert {r["label"]: r["name"] for r in records} == {1: "Left hippocampus", 2: "Right hippocampus",
                                                      12: "Hidden structure"}
    other = tmp_path / "other.ctbl"
    other.write_text("2 right 1 2 3 255\n")   # --label-names wins over the file beside; unlisted labels: null
    result = isoscope_here("measure", segmentation, "--labels", "--json", "--label-names", other)
    assert {r["label"]: r["name"] for r in json.loads(result.stdout)} == {1: None, 2: "right", 12: None}
    other.write_text("2 right 1 2 3\n")
    assert_one_line_error(isoscope_here("measure", segmentation, "--labels", "--label-names", other),
                          "other.ctbl line 1", "5 fields")
    assert_one_line_error(isoscope_here("measure", segmentation, "--label-names", other),
                          "--label-names needs --labels")
