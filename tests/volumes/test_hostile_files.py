"""Hostile volume files: each refused from its header or its first bad bytes, in one line, before it
allocates; or opened right. The corpus is made here from numpy (nibabel, pynrrd, pydicom, tifffile
and zarr write the files), never checked in.

Two layers: every case once through the real command (exit 2, one stderr line, seconds, peak RSS:
tests/support/command.py), and many generated damages of each format in-process (each opens to the same
samples or raises one VolumeError line, with nothing printed).
"""
from __future__ import annotations

import bz2
import gzip
import os
import shutil
import struct
import warnings
from pathlib import Path

import nibabel
import nrrd
import numpy as np
import pydicom
import pytest
import tifffile
import zarr
from support.command import refused, run_isoscope
from support.dicom_series import ct_ball, write_series  # noqa: E402

from isoscope.volumes import VolumeError, open_volume


@pytest.fixture
def blob():
    """A small volume with a surface: values 0..200 in a ball, uint8."""
    k, j, i = np.mgrid[:18, :17, :16]
    return np.clip(220 - 12 * np.sqrt((k - 9) ** 2 + (j - 8) ** 2 + (i - 7.5) ** 2), 0, 200).astype(np.uint8)


def export(path, *extra, **kwargs) -> str:
    return refused("export", path, "--out", Path(path).parent / "out.stl", *extra, **kwargs)


# ---- numpy files ---------------------------------------------------------------------------------

def test_npy_whose_header_dict_is_cut_off(tmp_path):
    header = b"{'descr': '<f4', 'shape': [1,2,"
    header += b" " * (118 - 10 - len(header) - 1) + b"\n"
    (tmp_path / "cut.npy").write_bytes(b"\x93NUMPY\x01\x00" + struct.pack("<H", len(header)) + header + bytes(64))
    export(tmp_path / "cut.npy", words=("cut.npy", "not a valid .npy", "np.save"))


def test_npz_whose_deflate_bytes_are_scrambled(tmp_path, blob):
    np.savez_compressed(tmp_path / "x.npz", v=blob.astype(np.float32))
    data = bytearray((tmp_path / "x.npz").read_bytes())
    for i in range(60, 200):
        data[i] ^= 0x5A
    (tmp_path / "x.npz").write_bytes(bytes(data))
    export(tmp_path / "x.npz", words=("x.npz", "damaged", "np.savez"))


# ---- NRRD ----------------------------------------------------------------------------------------

def test_nrrd_gzip_bomb_is_refused_while_inflating(tmp_path):
    header = b"NRRD0004\ntype: uint8\ndimension: 3\nsizes: 8 8 8\nencoding: gzip\n\n"
    (tmp_path / "bomb.nrrd").write_bytes(header + gzip.compress(bytes(256 << 20), compresslevel=9))
    export(tmp_path / "bomb.nrrd", words=("bomb.nrrd", "512 bytes", "decompression bomb"), extra_rss_mb=100)


def test_nrrd_bzip2_bomb_too(tmp_path):
    header = b"NRRD0004\ntype: short\ndimension: 3\nsizes: 4 4 4\nencoding: bzip2\n\n"
    (tmp_path / "bomb.nrrd").write_bytes(header + bz2.compress(bytes(64 << 20)))
    export(tmp_path / "bomb.nrrd", words=("128 bytes", "decompression bomb"), extra_rss_mb=100)


def test_nhdr_whose_data_file_is_a_fifo_does_not_block(tmp_path):
    os.mkfifo(tmp_path / "data.raw")
    (tmp_path / "f.nhdr").write_text("NRRD0004\ntype: uint8\ndimension: 3\nsizes: 8 8 8\nencoding: raw\n"
                                     "data file: data.raw\n\n")
    export(tmp_path / "f.nhdr", words=("data.raw", "named pipe", "regular file"))


def test_a_volume_path_that_is_a_fifo_does_not_block(tmp_path):
    os.mkfifo(tmp_path / "scan.nii")
    export(tmp_path / "scan.nii", words=("scan.nii", "named pipe"))


def test_nrrd_reads_every_encoding_and_skip_exactly(tmp_path, blob):
    """The bounded reader gives pynrrd's samples for each encoding, attached and detached, with skips."""
    values = blob.astype(np.int16) - 50
    for encoding in ("raw", "gzip", "bzip2", "ascii"):
        for detached in (False, True):
            path = tmp_path / f"{encoding}{'.nhdr' if detached else '.nrrd'}"
            nrrd.write(str(path), values, {"encoding": encoding, "endian": "big"}, detached_header=detached)
            assert np.array_equal(open_volume(str(path)).data, values), path.name
    # byte skip -1 (the samples are the data file's last bytes) and line skip over a text preamble
    (tmp_path / "skip.raw").write_bytes(b"a preamble line\nanother\n" + bytes(7) + values.astype("<i2").tobytes("F"))
    (tmp_path / "skip.nhdr").write_text("NRRD0004\ntype: short\ndimension: 3\nsizes: 18 17 16\nencoding: raw\n"
                                        "endian: little\nline skip: 2\nbyte skip: -1\ndata file: skip.raw\n\n")
    assert np.array_equal(open_volume(str(tmp_path / "skip.nhdr")).data, values)


def test_nrrd_with_collinear_space_directions_exports_in_index_space(tmp_path, blob):
    nrrd.write(str(tmp_path / "c.nrrd"), blob, {"space": "left-posterior-superior", "space origin": [0, 0, 0],
                                                "space directions": [[1, 0, 0], [2, 0, 0], [0, 0, 1]]})
    run = run_isoscope("export", tmp_path / "c.nrrd", "--out", tmp_path / "c.stl")
    assert run.returncode == 0 and run.stderr == "", run.stderr
    assert "index x spacing coordinates" in run.stdout
    assert any("index-to-world matrix" in note and "same way" in note
               for note in open_volume(str(tmp_path / "c.nrrd")).notes)


# ---- NIfTI ---------------------------------------------------------------------------------------

def test_nifti_gz_with_flipped_bytes_fails_its_crc(tmp_path, blob):
    big = np.tile(blob, (3, 3, 3))
    nibabel.save(nibabel.Nifti1Image(big, np.eye(4)), tmp_path / "scan.nii.gz")
    data = bytearray((tmp_path / "scan.nii.gz").read_bytes())
    middle = len(data) // 2
    for i in range(middle, middle + 64):
        data[i] ^= 0xFF
    (tmp_path / "scan.nii.gz").write_bytes(bytes(data))
    line = export(tmp_path / "scan.nii.gz", words=("scan.nii.gz", "export it again"))
    assert "CRC check failed" in line or "corrupt" in line, line


def test_nifti_gz_whose_body_inflates_past_its_header(tmp_path):
    header = nibabel.Nifti1Header()
    header.set_data_shape((8, 8, 8))
    header.set_data_dtype(np.uint8)
    with gzip.open(tmp_path / "bomb.nii.gz", "wb") as out:
        out.write(header.binaryblock + bytes(4))
        for _ in range(64):
            out.write(bytes(1 << 20))  # 64 MiB of zeros behind 512 bytes of samples
    export(tmp_path / "bomb.nii.gz", words=("bomb.nii.gz", "decompression bomb"), extra_rss_mb=100)


def test_nifti_header_of_more_samples_than_one_extraction_is_refused_before_reading(tmp_path):
    """1400^3 uint8 fits in memory here but not in one extractor: `export` says so from the header
    (the file holds only a few samples: nothing past the header is read)."""
    header = nibabel.Nifti1Header()
    header.set_data_shape((1400, 1400, 1400))
    header.set_data_dtype(np.uint8)
    with gzip.open(tmp_path / "big.nii.gz", "wb") as out:
        out.write(header.binaryblock + bytes(4) + bytes(4096))
    line = export(tmp_path / "big.nii.gz", words=("big.nii.gz", "1400x1400x1400", "--chunk"), seconds=5)
    assert "2,744,000,000 samples" in line


def test_the_header_check_is_the_extractors_own_rule():
    """Rows are whole 32-sample words: 1100x1000x970 has fewer samples than 2^30 and still more words than
    one extractor takes, and the open refuses it as plan_extractor would; 1024^3 passes both."""
    from isoscope.core.layout import fits_one_extraction
    from isoscope.gpu.limits import GPULimitError, GpuLimits, plan_extractor
    roomy = GpuLimits(max_3d_texture_size=1 << 30, max_texture_size=1 << 30, max_storage_block_bytes=1 << 40)
    for shape in [(1100, 1000, 970), (1024, 1024, 1024), (1024, 1024, 1025), (2, 2, 1 << 30)]:
        try:
            plan_extractor(shape, roomy)
            planned = True
        except GPULimitError as exc:
            planned = "sign words" not in str(exc)
        assert fits_one_extraction(shape) == planned, shape
    assert 1100 * 1000 * 970 < 1 << 30 and not fits_one_extraction((1100, 1000, 970))


def test_nifti_library_chatter_becomes_notes(tmp_path, blob):
    nibabel.save(nibabel.Nifti1Image(blob, np.eye(4)), tmp_path / "pix.nii")
    data = bytearray((tmp_path / "pix.nii").read_bytes())
    struct.pack_into("<f", data, 80, 0.0)  # pixdim[1] = 0: nibabel logs a fix, twice
    (tmp_path / "pix.nii").write_bytes(bytes(data))
    run = run_isoscope("export", tmp_path / "pix.nii", "--out", tmp_path / "p.stl")
    assert run.returncode == 0 and run.stderr == "", run.stderr
    assert any("pixdim" in note for note in open_volume(str(tmp_path / "pix.nii")).notes)


def test_nifti_zeroed_sform_falls_back_to_the_qform(tmp_path, blob):
    qform = np.diag([2.0, 3.0, 4.0, 1.0])
    qform[:3, 3] = (10, 20, 30)
    image = nibabel.Nifti1Image(blob, qform)
    image.header.set_qform(qform, code=1)
    image.header.set_sform(qform, code=1)
    nibabel.save(image, tmp_path / "z.nii")
    data = bytearray((tmp_path / "z.nii").read_bytes())
    data[280:328] = bytes(48)  # srow_x, srow_y, srow_z: all zero, sform_code still 1
    (tmp_path / "z.nii").write_bytes(bytes(data))
    volume = open_volume(str(tmp_path / "z.nii"))
    assert volume.world is not None and np.allclose(volume.world[0], qform)


# ---- DICOM ---------------------------------------------------------------------------------------

def _series(tmp_path, name):
    folder = tmp_path / name
    write_series(folder, ct_ball())
    return folder, sorted(folder.glob("*.dcm"))


def _edit(path, change):
    dataset = pydicom.dcmread(path)
    change(dataset)
    dataset.save_as(path)


def test_dicom_slice_with_empty_rows(tmp_path):
    folder, files = _series(tmp_path, "rows")
    _edit(files[3], lambda ds: setattr(ds, "Rows", None))
    export(folder, words=(files[3].name, "Rows and Columns", "damaged"))


def test_dicom_slice_without_pixel_data(tmp_path):
    folder, files = _series(tmp_path, "nopixels")
    _edit(files[3], lambda ds: delattr(ds, "PixelData"))
    export(folder, words=(files[3].name, "no pixel data"))


def test_dicom_rescale_slope_beyond_float32(tmp_path):
    folder, files = _series(tmp_path, "slope")
    for path in files:
        _edit(path, lambda ds: setattr(ds, "RescaleSlope", "1e39"))
    line = export(folder, words=("RescaleSlope", "float32"))
    assert "RuntimeWarning" not in line


def test_dicom_orientation_with_five_values(tmp_path):
    folder, files = _series(tmp_path, "iop")
    for path in files:
        _edit(path, lambda ds: setattr(ds, "ImageOrientationPatient", list(ds.ImageOrientationPatient)[:5]))
    export(folder, words=("ImageOrientationPatient has 5 values", "6"))


def test_dicom_one_rgb_slice(tmp_path):
    folder, files = _series(tmp_path, "rgb")

    def to_rgb(ds):
        grey = (ds.pixel_array // 8).astype(np.uint8)
        ds.SamplesPerPixel, ds.PhotometricInterpretation, ds.PlanarConfiguration = 3, "RGB", 0
        ds.BitsAllocated, ds.BitsStored, ds.HighBit, ds.PixelRepresentation = 8, 8, 7, 0
        ds.PixelData = np.stack([grey] * 3, axis=-1).tobytes()
    _edit(files[3], to_rgb)
    export(folder, words=(files[3].name, "colour image", "3 samples per pixel"))


def test_dicom_truncated_uncompressed_slice_is_called_damaged(tmp_path):
    folder, files = _series(tmp_path, "cut")
    files[3].write_bytes(files[3].read_bytes()[:-200])
    line = export(folder, words=(files[3].name, "damaged or truncated"))
    assert "compressed" not in line


def test_dicom_slice_of_another_sample_type_is_not_cast_silently(tmp_path):
    folder, files = _series(tmp_path, "mixed")
    _edit(files[5], lambda ds: setattr(ds, "PixelRepresentation", 0))  # uint16 among int16 slices
    for path in files:
        _edit(path, lambda ds: (setattr(ds, "RescaleSlope", 1), setattr(ds, "RescaleIntercept", 0)))
    with pytest.raises(VolumeError, match=f"{files[5].name} stores its samples as uint16 .* int16"):
        open_volume(str(folder))


def test_dicom_size_is_refused_from_the_headers(tmp_path):
    folder, files = _series(tmp_path, "huge")
    for path in files:
        _edit(path, lambda ds: (setattr(ds, "Rows", 30000), setattr(ds, "Columns", 30000)))
    export(folder, words=("huge", "12x30000x30000"), seconds=6)


# ---- TIFF ----------------------------------------------------------------------------------------

def test_tiff_size_is_refused_from_its_tags(tmp_path, blob):
    tifffile.imwrite(tmp_path / "huge.tif", blob[:8])
    with tifffile.TiffFile(tmp_path / "huge.tif", mode="r+b") as tif:
        for page in tif.pages:
            page.tags["ImageWidth"].overwrite(46000)
            page.tags["ImageLength"].overwrite(46000)
    export(tmp_path / "huge.tif", words=("huge.tif", "8x46000x46000"))


def test_tiff_log_lines_stay_off_stderr(tmp_path, blob):
    tifffile.imwrite(tmp_path / "b.tif", blob)
    data = bytearray((tmp_path / "b.tif").read_bytes())
    first = struct.unpack("<I", data[4:8])[0]
    entries = struct.unpack("<H", data[first:first + 2])[0]
    struct.pack_into("<I", data, first + 2 + 12 * entries, len(data) + 100_000)  # next page: past the end
    (tmp_path / "b.tif").write_bytes(bytes(data))
    run = run_isoscope("export", tmp_path / "b.tif", "--out", tmp_path / "b.stl")
    assert run.returncode == 0 and run.stderr == "", run.stderr


# ---- Zarr ----------------------------------------------------------------------------------------

def test_zarr_whose_chunks_are_random_bytes(tmp_path, blob):
    array = zarr.open(str(tmp_path / "r.zarr"), mode="w", shape=blob.shape, chunks=(8, 8, 8), dtype="f4")
    array[:] = blob
    chunks = [p for p in (tmp_path / "r.zarr").rglob("*") if p.is_file() and p.name != "zarr.json"]
    assert chunks
    for path in chunks:
        path.write_bytes(np.random.default_rng(len(str(path))).bytes(200))
    export(tmp_path / "r.zarr", words=("r.zarr", "chunk", "cannot be read", "damaged"))


def test_zarr_metadata_of_a_monster(tmp_path):
    zarr.open(str(tmp_path / "m.zarr"), mode="w", shape=(100000,) * 3, chunks=(256,) * 3, dtype="f4")
    export(tmp_path / "m.zarr", words=("m.zarr", "100000x100000x100000", "samples"))


def test_zarr_of_tiny_chunks(tmp_path):
    zarr.open(str(tmp_path / "t.zarr"), mode="w", shape=(2000,) * 3, chunks=(1,) * 3, dtype="f4")
    export(tmp_path / "t.zarr", words=("t.zarr", "1x1x1 chunks", "rechunk"))


# ---- generated damage, in-process ----------------------------------------------------------------

def _write(kind: str, path: Path, volume: np.ndarray) -> Path:
    if kind == "npy":
        np.save(path, volume)
    elif kind == "npz":
        np.savez_compressed(path, v=volume)
    elif kind == "nrrd-gzip":
        nrrd.write(str(path), volume, {"encoding": "gzip"})
    elif kind == "nrrd-raw":
        nrrd.write(str(path), volume, {"encoding": "raw"})
    elif kind == "nii.gz":
        nibabel.save(nibabel.Nifti1Image(volume, np.eye(4)), path)
    elif kind == "tif":
        tifffile.imwrite(path, volume)
    return path


SUFFIX = {"npy": ".npy", "npz": ".npz", "nrrd-gzip": ".nrrd", "nrrd-raw": ".nrrd", "nii.gz": ".nii.gz",
          "tif": ".tif"}
CHECKSUMMED = {"npz", "nrrd-gzip", "nii.gz"}  # a damaged file that still opens must hold the same samples


@pytest.mark.parametrize("kind", list(SUFFIX))
def test_generated_damage_opens_right_or_is_one_line(tmp_path, blob, kind, capfd):
    """40 damaged copies of each format (cut short, a byte run flipped, a header byte changed):
    each opens or is refused in one VolumeError line, and nothing else reaches stderr. Where the
    format checksums its data, what opens is the original."""
    rng = np.random.default_rng(sum(map(ord, kind)))
    good = _write(kind, tmp_path / f"good{SUFFIX[kind]}", blob).read_bytes()
    outcomes = {"opened": 0, "refused": 0}
    for case in range(40):
        data = bytearray(good)
        damage = case % 3
        if damage == 0:
            data = data[:int(rng.integers(1, len(data)))]
        else:
            lo, hi = (0, min(len(data), 400)) if damage == 2 else (0, len(data))
            start = int(rng.integers(lo, hi - 1))
            for i in range(start, min(start + int(rng.integers(1, 64)), len(data))):
                data[i] ^= int(rng.integers(1, 256))
        path = tmp_path / f"case{case}{SUFFIX[kind]}"
        path.write_bytes(bytes(data))
        try:
            volume = open_volume(str(path))
        except VolumeError as exc:
            assert "\n" not in str(exc) and str(exc), exc
            outcomes["refused"] += 1
        else:
            outcomes["opened"] += 1
            if kind in CHECKSUMMED:
                assert np.array_equal(np.asarray(volume.data), blob), f"case {case}: wrong samples accepted"
        path.unlink()
    assert outcomes["refused"] > 0, outcomes
    assert capfd.readouterr().err == ""


def test_generated_dicom_damage(tmp_path, capfd):
    """Header fields of one slice emptied or set to nonsense, 24 ways: each series opens or is refused
    in one line."""
    source = tmp_path / "source"
    write_series(source, ct_ball())
    rng = np.random.default_rng(7)
    keywords = ["Rows", "Columns", "ImagePositionPatient", "ImageOrientationPatient", "PixelSpacing",
                "RescaleSlope", "RescaleIntercept", "BitsAllocated", "SamplesPerPixel", "PixelData"]
    nonsense = [None, "", "0", "-1", "nan", "1e39", [1.0, 2.0], [0.0] * 6, "abc"]
    for case in range(24):
        folder = tmp_path / f"case{case}"
        shutil.copytree(source, folder)
        files = sorted(folder.glob("*.dcm"))
        target = files[int(rng.integers(len(files)))]
        keyword, value = keywords[case % len(keywords)], nonsense[int(rng.integers(len(nonsense)))]
        dataset = pydicom.dcmread(target)
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")  # pydicom warns of the nonsense it is asked to write
                if value is None:
                    delattr(dataset, keyword)
                else:
                    setattr(dataset, keyword, value)
                dataset.save_as(target)
        except (ValueError, TypeError, OverflowError, OSError, struct.error):
            continue  # pydicom itself will not write that value
        try:
            open_volume(str(folder))
        except VolumeError as exc:
            assert "\n" not in str(exc), exc
        shutil.rmtree(folder)
    assert capfd.readouterr().err == ""


def test_a_lazy_volume_is_scanned_in_bounded_blocks(monkeypatch):
    """A lazy volume whose one plane is bigger than the scan's slab is read in pieces of a plane
    (a Zarr of 10^5 x 10^5 planes asked numpy for a 37 GiB plane), and its range and first bad
    sample are found all the same."""
    from isoscope import validation

    class Recording:
        def __init__(self, array):
            self.array, self.shape, self.dtype, self.largest = array, array.shape, array.dtype, 0

        def __getitem__(self, index):
            block = self.array[index]
            self.largest = max(self.largest, block.nbytes)
            return block

    monkeypatch.setattr(validation, "CHECK_SLAB_BYTES", 4096)
    values = np.random.default_rng(3).random((3, 70, 50)).astype(np.float32)  # a plane: 14,000 bytes
    lazy = Recording(values)
    assert validation.check_volume(lazy).value_range == (float(values.min()), float(values.max()))
    assert 0 < lazy.largest <= 4096
    values[2, 61, 7] = np.nan
    with pytest.raises(ValueError, match=r"1 NaN/Inf sample\(s\), the first \(nan\) at index \(2, 61, 7\)"):
        validation.check_volume(Recording(values))


# ---- generated headers (hypothesis) --------------------------------------------------------------

from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

_FUZZ = settings(max_examples=120, deadline=None, derandomize=True,
                 suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
_SIZES = st.one_of(st.integers(-3, 12), st.integers(2**31 - 2, 2**33), st.sampled_from([0, 1, 10**18]))
_NRRD_TYPES = ["uint8", "short", "int", "float", "double", "long long", "block", "complex", "uchar"]
_ENCODINGS = ["raw", "gzip", "bzip2", "ascii", "hex", "zip"]


def _opens_or_one_line(spec: str, **options) -> None:
    try:
        open_volume(spec, **options)
    except VolumeError as exc:
        assert str(exc) and "\n" not in str(exc), exc


@_FUZZ
@given(sizes=st.lists(_SIZES, min_size=0, max_size=5), kind=st.sampled_from(_NRRD_TYPES),
       encoding=st.sampled_from(_ENCODINGS), byte_skip=st.integers(-3, 100), line_skip=st.integers(-2, 3),
       body=st.binary(max_size=600), detached=st.booleans(), data_file=st.sampled_from(["data.raw", "missing.raw",
                                                                                          "LIST", "d%03d.raw"]))
def test_generated_nrrd_headers(tmp_path_factory, sizes, kind, encoding, byte_skip, line_skip, body, detached,
                                data_file):
    """Any header pynrrd parses (sizes of every size, every type and encoding, skips, detached data
    files that are missing or lists), over a short random body: a volume or one line, quickly."""
    folder = tmp_path_factory.mktemp("nrrd")
    header = (f"NRRD0004\ntype: {kind}\ndimension: {max(1, len(sizes))}\nsizes: {' '.join(map(str, sizes))}\n"
              f"encoding: {encoding}\nbyte skip: {byte_skip}\nline skip: {line_skip}\n")
    if detached:
        (folder / "data.raw").write_bytes(body)
        (folder / "v.nhdr").write_text(header + f"data file: {data_file}\n\n")
        _opens_or_one_line(str(folder / "v.nhdr"))
    else:
        (folder / "v.nrrd").write_bytes(header.encode() + b"\n" + body)
        _opens_or_one_line(str(folder / "v.nrrd"))


_JSON = st.recursive(st.one_of(st.none(), st.booleans(), st.integers(-2**40, 2**40), st.floats(allow_nan=True),
                               st.text(max_size=8)),
                     lambda inner: st.lists(inner, max_size=4), max_leaves=8)


@_FUZZ
@given(dims=_JSON, dtype=st.one_of(st.sampled_from(["uint8", "float32", "int16", "f8", "object"]), _JSON),
       spacing=_JSON, endian=st.one_of(st.sampled_from(["little", "big"]), _JSON), size=st.integers(0, 300))
def test_generated_raw_sidecars(tmp_path_factory, dims, dtype, spacing, endian, size):
    """A raw file's JSON sidecar with any values where its keys are (nested lists, huge numbers, NaN,
    strings): a volume or one line."""
    import json
    folder = tmp_path_factory.mktemp("raw")
    (folder / "v.raw").write_bytes((bytes(range(256)) * 2)[:size])
    (folder / "v.raw.json").write_text(json.dumps({"dims": dims, "dtype": dtype, "spacing": spacing,
                                                   "endian": endian}))
    _opens_or_one_line(str(folder / "v.raw"))


@_FUZZ
@given(dims=st.lists(st.integers(-5, 40), min_size=8, max_size=8), datatype=st.sampled_from(
    [0, 1, 2, 4, 8, 16, 32, 64, 128, 256, 512, 768, 1024, 1536, 2048, 2304, 77]),
    pixdim=st.lists(st.floats(allow_nan=True, allow_infinity=True, width=32), min_size=8, max_size=8),
    vox_offset=st.sampled_from([0.0, 348.0, 352.0, 400.0, -4.0, 1e30]), slope=st.floats(width=32),
    gz=st.booleans())
def test_generated_nifti_headers(tmp_path_factory, dims, datatype, pixdim, vox_offset, slope, gz):
    """NIfTI-1 headers with any dim, datatype, pixdim, vox_offset and scl_slope over 4 KiB of data:
    a volume or one line (nibabel's own complaints become notes or the line)."""
    header = bytearray(348)
    struct.pack_into("<i", header, 0, 348)
    struct.pack_into("<8h", header, 40, *dims)
    struct.pack_into("<h", header, 70, datatype)
    struct.pack_into("<8f", header, 76, *pixdim)
    struct.pack_into("<f", header, 108, vox_offset)
    struct.pack_into("<f", header, 112, slope)
    header[344:348] = b"n+1\0"
    data = bytes(header) + bytes(4) + np.random.default_rng(len(dims)).bytes(4096)
    folder = tmp_path_factory.mktemp("nii")
    path = folder / ("v.nii.gz" if gz else "v.nii")
    path.write_bytes(gzip.compress(data) if gz else data)
    _opens_or_one_line(str(path))


_DESCR = st.one_of(st.sampled_from(["<f4", ">f8", "|u1", "<i2", "|b1", "<c8", "|O", "<U3", "|V4", "<M8[s]",
                                    "[('a', '<f4')]", "<f2", "|S2"]), st.text(max_size=6))
_SHAPE = st.one_of(st.lists(st.integers(-2, 40), max_size=5).map(tuple),
                   st.lists(st.integers(2**31, 2**62), min_size=3, max_size=3).map(tuple), st.text(max_size=5))


@_FUZZ
@given(descr=_DESCR, shape=_SHAPE, fortran=st.one_of(st.booleans(), st.integers(), st.none()),
       body=st.binary(max_size=2000), version=st.sampled_from([(1, 0), (2, 0), (3, 0), (9, 9)]))
def test_generated_npy_headers(tmp_path_factory, descr, shape, fortran, body, version):
    """An .npy header dict with any descr, shape and fortran_order (written as text, as numpy writes
    it), over a random body: a volume or one line; never unpickled."""
    text = f"{{'descr': {descr!r}, 'fortran_order': {fortran!r}, 'shape': {shape!r}, }}"
    text += " " * (63 - (len(text) + 10) % 64) + "\n"
    size = struct.pack("<H", len(text)) if version[0] == 1 else struct.pack("<I", len(text))
    path = tmp_path_factory.mktemp("npy") / "v.npy"
    path.write_bytes(b"\x93NUMPY" + bytes(version) + size + text.encode("latin1", "replace") + body)
    _opens_or_one_line(str(path))
