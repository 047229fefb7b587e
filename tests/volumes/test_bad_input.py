"""Every bad input is one VolumeError line naming the problem and the fix.

One test per kind of bad input, each on a real file written here.
"""
from __future__ import annotations

import gzip
import json
import os
import pickle
import tracemalloc

import nibabel
import nrrd
import numpy as np
import pytest

from isoscope.volumes import VolumeError, open_volume


def refused(spec, *words, **options) -> str:
    """Open spec, expect a VolumeError whose one line contains every word; return it."""
    with pytest.raises(VolumeError) as caught:
        open_volume(str(spec), **options)
    message = str(caught.value)
    assert "\n" not in message and "Traceback" not in message
    for word in words:
        assert word.lower() in message.lower(), message
    return message


@pytest.fixture
def cube():
    return np.linspace(-1.0, 1.0, 4 * 4 * 4, dtype=np.float32).reshape(4, 4, 4)


def test_missing_file(tmp_path):
    refused(tmp_path / "nothing.nii", "no such file", "nothing.nii")


def test_misspelt_builtin_gets_a_suggestion():
    refused("spher", "no such file or built-in", "did you mean sphere")


def test_unknown_format(tmp_path):
    (tmp_path / "notes.txt").write_text("hello")
    refused(tmp_path / "notes.txt", "unknown volume format", ".nrrd", "--dims")


def test_truncated_raw(tmp_path):
    np.zeros(4 * 4 * 3, np.uint8).tofile(tmp_path / "t.raw")
    refused(tmp_path / "t.raw", "truncated", "64 bytes", "48", dims=(4, 4, 4))


def test_oversized_raw(tmp_path):
    np.zeros(4 * 4 * 4 + 16, np.uint8).tofile(tmp_path / "o.raw")
    refused(tmp_path / "o.raw", "larger than its layout", "16 extra", dims=(4, 4, 4))


def test_raw_dims_that_do_not_match_the_size_suggest_a_dtype(tmp_path):
    np.zeros(4 * 4 * 4, np.float32).tofile(tmp_path / "f.raw")
    refused(tmp_path / "f.raw", "--dims 4 4 4", "try --dtype", "float32", dims=(4, 4, 4), dtype="uint8")


def test_dims_that_contradict_a_header(tmp_path, cube):
    np.save(tmp_path / "c.npy", cube)
    refused(tmp_path / "c.npy", "--dims 4 4 5", "4x4x4", "drop --dims", dims=(4, 4, 5))


def test_raw_without_dims(tmp_path):
    np.zeros(64, np.uint8).tofile(tmp_path / "n.raw")
    refused(tmp_path / "n.raw", "--dims x y z", "n.raw.json")


def test_bad_sidecar(tmp_path):
    np.zeros(64, np.uint8).tofile(tmp_path / "s.raw")
    (tmp_path / "s.raw.json").write_text("{dims: 4 4 4}")
    refused(tmp_path / "s.raw", "not valid json")
    (tmp_path / "s.raw.json").write_text(json.dumps({"dims": [4, 4, 4], "shape": 1}))
    refused(tmp_path / "s.raw", "unknown key", "shape")


def _refused_without_allocating(spec, *words, **options):
    tracemalloc.start()
    try:
        refused(spec, *words, **options)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 8 << 20, f"allocated {peak} bytes before refusing"


def test_nrrd_header_claiming_more_voxels_than_memory(tmp_path):
    (tmp_path / "huge.raw").write_bytes(b"\0" * 16)
    (tmp_path / "huge.nhdr").write_text(
        "NRRD0004\ntype: float\ndimension: 3\nsizes: 100000 100000 100000\n"
        "encoding: raw\nendian: little\ndata file: huge.raw\n")
    _refused_without_allocating(tmp_path / "huge.nhdr", "100000x100000x100000", "more than this machine",
                                "crop or downsample")


def test_npy_header_claiming_more_voxels_than_memory(tmp_path):
    with open(tmp_path / "huge.npy", "wb") as fp:
        np.lib.format.write_array_header_2_0(fp, {"descr": "<f4", "fortran_order": False,
                                                  "shape": (50000, 50000, 50000)})
    _refused_without_allocating(tmp_path / "huge.npy", "50000x50000x50000", "more than this machine")


def test_nifti_header_claiming_more_voxels_than_memory(tmp_path):
    header = nibabel.Nifti1Header()
    header.set_data_shape((30000, 30000, 30000))
    header.set_data_dtype(np.int16)
    with open(tmp_path / "huge.nii", "wb") as fp:
        header.write_to(fp)
        fp.write(b"\0" * (int(header.get_data_offset()) - fp.tell()))
    _refused_without_allocating(tmp_path / "huge.nii", "30000x30000x30000", "more than this machine")


def test_raw_dims_claiming_more_voxels_than_memory(tmp_path):
    np.zeros(64, np.uint8).tofile(tmp_path / "r.raw")
    _refused_without_allocating(tmp_path / "r.raw", "more than this machine", dims=(90000, 90000, 90000))


def _nifti_gz_bytes(tmp_path, cube) -> bytes:
    nibabel.save(nibabel.Nifti1Image(cube, np.eye(4)), str(tmp_path / "ok.nii.gz"))
    return (tmp_path / "ok.nii.gz").read_bytes()


def test_corrupt_gzip_nifti(tmp_path, cube):
    data = bytearray(_nifti_gz_bytes(tmp_path, cube))
    data[40:60] = b"\xff" * 20  # inside the deflate stream
    (tmp_path / "bad.nii.gz").write_bytes(bytes(data))
    refused(tmp_path / "bad.nii.gz", "corrupt", "again")


def test_truncated_gzip_nifti(tmp_path, cube):
    data = _nifti_gz_bytes(tmp_path, cube)
    (tmp_path / "cut.nii.gz").write_bytes(data[: len(data) // 3])
    refused(tmp_path / "cut.nii.gz", "truncated", "again")


def test_corrupt_gzip_nrrd(tmp_path):
    volume = np.random.default_rng(0).random((8, 8, 8))
    nrrd.write(str(tmp_path / "g.nrrd"), volume, {"encoding": "gzip"})
    data = bytearray((tmp_path / "g.nrrd").read_bytes())
    data[-30:-20] = b"\0" * 10
    (tmp_path / "g.nrrd").write_bytes(bytes(data))
    refused(tmp_path / "g.nrrd", "corrupt", "again")


def test_not_a_gzip_at_all(tmp_path):
    (tmp_path / "plain.nii.gz").write_bytes(gzip.compress(b"not a nifti") [:5])
    refused(tmp_path / "plain.nii.gz", "plain.nii.gz")


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_nan_or_inf_samples(tmp_path, cube, bad):
    cube[1, 2, 3] = bad
    np.save(tmp_path / "n.npy", cube)
    refused(tmp_path / "n.npy", "1 nan/inf sample", "(1, 2, 3)", "nan_to_num")


def test_constant_volume(tmp_path):
    np.save(tmp_path / "c.npy", np.full((5, 5, 5), 7, dtype=np.int16))
    refused(tmp_path / "c.npy", "constant", "every sample is 7", "no level has a surface")


def test_non_numeric_array(tmp_path):
    np.save(tmp_path / "s.npy", np.array(["a", "b"] * 4).reshape(2, 2, 2))
    refused(tmp_path / "s.npy", "not numbers", "astype")


def test_complex_array(tmp_path):
    np.save(tmp_path / "c.npy", np.ones((3, 3, 3), dtype=np.complex64))
    refused(tmp_path / "c.npy", "complex", "np.abs")


class _Sentinel:
    """Unpickling this would create a file: proof the loader never unpickles."""

    def __init__(self, path):
        self.path = path

    def __reduce__(self):
        return (open, (self.path, "w"))


def test_pickled_object_array_is_never_unpickled(tmp_path):
    canary = str(tmp_path / "unpickled")
    np.save(tmp_path / "p.npy", np.array([_Sentinel(canary)] * 8, dtype=object).reshape(2, 2, 2),
            allow_pickle=True)
    refused(tmp_path / "p.npy", "python objects", "never loads")
    assert not os.path.exists(canary)


def test_pickle_in_an_npz_is_never_unpickled(tmp_path):
    canary = str(tmp_path / "unpickled")
    np.savez(tmp_path / "p.npz", volume=np.array([_Sentinel(canary)] * 8, dtype=object).reshape(2, 2, 2))
    refused(tmp_path / "p.npz", "python objects")
    assert not os.path.exists(canary)


def test_plain_pickle_named_npy(tmp_path):
    (tmp_path / "x.npy").write_bytes(pickle.dumps(_Sentinel(str(tmp_path / "unpickled"))))
    refused(tmp_path / "x.npy", "not a valid .npy", "np.save")
    assert not os.path.exists(tmp_path / "unpickled")


@pytest.mark.parametrize("shape", [(10,), (6, 7)])
def test_1d_and_2d_arrays(tmp_path, shape):
    np.save(tmp_path / "a.npy", np.arange(np.prod(shape), dtype=np.float32).reshape(shape))
    refused(tmp_path / "a.npy", f"{len(shape)}-d array", "needs a 3-d array", "np.stack")


def test_flat_axis_is_refused(tmp_path):
    np.save(tmp_path / "f.npy", np.arange(20, dtype=np.float32).reshape(4, 5, 1))
    refused(tmp_path / "f.npy", "4x5x1", "at least 2 samples")


@pytest.mark.parametrize("text, column, words", [
    ("x + foo(y)", 5, ["unknown name 'foo'"]),
    ("2x + 1", 2, ["missing operator", "2*x"]),
    ("sin(x", 6, ["expected ')'"]),
    ("x +", 4, ["complete the formula"]),
    ("x # y", 3, ["unexpected character '#'"]),
    ("max(x)", 1, ["max takes 2 argument"]),
])
def test_expression_that_fails_to_parse_points_at_the_column(text, column, words):
    refused(f"expr:{text}", f"column {column}", *words)


def test_expression_with_nan_names_the_point():
    refused("expr:sqrt(x); res=5", "nan/inf", "x=-1", "change the formula or the box", backend="cpu")


def test_frame_out_of_range_and_frame_on_3d(tmp_path, cube):
    np.save(tmp_path / "t.npy", np.stack([cube, -cube]))
    refused(tmp_path / "t.npy", "--time 2 is past the end", "0..1", time=2)
    np.save(tmp_path / "c.npy", cube)
    refused(tmp_path / "c.npy", "3-d", "drop --time", time=0)


def test_file_flags_on_a_builtin():
    refused("sphere", "built-in", "drop --dims", dims=(4, 4, 4))
