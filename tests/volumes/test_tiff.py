"""TIFF stacks through tifffile: ImageJ and OME metadata give the spacing; time is frames; colour is refused."""
from __future__ import annotations

import numpy as np
import pytest
import tifffile

from isoscope.volumes import VolumeError, open_volume

STACK = (np.arange(5 * 6 * 7) % 251).astype(np.uint16).reshape(5, 6, 7) * 3


def test_an_imagej_stack_keeps_its_voxel_size(tmp_path):
    tifffile.imwrite(tmp_path / "cells.tif", STACK, imagej=True, resolution=(1 / 0.25, 1 / 0.3),
                     metadata={"spacing": 2.0, "unit": "um", "axes": "ZYX"})
    volume = open_volume(str(tmp_path / "cells.tif"))
    np.testing.assert_array_equal(volume.data, STACK)
    assert volume.spacing == pytest.approx((2.0, 0.3, 0.25))   # z, y, x
    assert volume.length_unit == "micrometer"   # measure converts it to mm


@pytest.mark.parametrize("unit, expected", [("micron", "micron"), ("\\u00B5m", "micrometer"), ("pixel", None),
                                            ("furlong", None)])
def test_an_imagej_stack_s_unit_is_its_length_unit(tmp_path, unit, expected):
    """ImageJ writes "micron" or an escaped µm; "pixel" is no calibration; an unknown unit is noted, taken as mm."""
    tifffile.imwrite(tmp_path / "cells.tif", STACK, imagej=True, resolution=(4, 3),
                     metadata={"spacing": 2.0, "unit": unit, "axes": "ZYX"})
    volume = open_volume(str(tmp_path / "cells.tif"))
    assert volume.length_unit == expected
    assert any("'furlong'] are not one length unit" in note for note in volume.notes) == (unit == "furlong")


def test_an_ome_tiff_keeps_its_physical_sizes(tmp_path):
    tifffile.imwrite(tmp_path / "cells.ome.tif", STACK, ome=True,
                     metadata={"axes": "ZYX", "PhysicalSizeX": 0.3, "PhysicalSizeY": 0.25, "PhysicalSizeZ": 2.0})
    volume = open_volume(str(tmp_path / "cells.ome.tif"))
    np.testing.assert_array_equal(volume.data, STACK)
    assert volume.spacing == pytest.approx((2.0, 0.25, 0.3))
    assert volume.length_unit == "micrometer"   # the OME schema's default PhysicalSize*Unit
    tifffile.imwrite(tmp_path / "nm.ome.tif", STACK, ome=True,
                     metadata={"axes": "ZYX", "PhysicalSizeX": 3, "PhysicalSizeY": 3, "PhysicalSizeZ": 20,
                               **{f"PhysicalSize{a}Unit": "nm" for a in "XYZ"}})
    assert open_volume(str(tmp_path / "nm.ome.tif")).length_unit == "nanometer"


def test_a_plain_stack_without_metadata_has_unit_spacing(tmp_path):
    tifffile.imwrite(tmp_path / "plain.tiff", STACK)
    volume = open_volume(str(tmp_path / "plain.tiff"))
    np.testing.assert_array_equal(volume.data, STACK)
    assert volume.spacing == (1.0, 1.0, 1.0) and volume.length_unit is None


def test_a_time_series_is_frames_and_colour_is_refused(tmp_path):
    movie = np.stack([STACK, STACK + 1000])
    tifffile.imwrite(tmp_path / "movie.tif", movie, imagej=True, metadata={"axes": "TZYX"})
    np.testing.assert_array_equal(open_volume(str(tmp_path / "movie.tif"), time=1).data, STACK + 1000)
    colour = np.stack([STACK, STACK], axis=1)                     # Z C Y X
    tifffile.imwrite(tmp_path / "colour.tif", colour, imagej=True, metadata={"axes": "ZCYX"})
    with pytest.raises(VolumeError, match="colour channels"):
        open_volume(str(tmp_path / "colour.tif"))


def test_a_damaged_tiff_is_a_one_line_error(tmp_path):
    (tmp_path / "broken.tif").write_bytes(b"II*\x00garbage")
    with pytest.raises(VolumeError) as err:
        open_volume(str(tmp_path / "broken.tif"))
    assert "broken.tif" in str(err.value) and "\n" not in str(err.value)
