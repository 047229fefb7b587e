"""A small asymmetric "head" in patient coordinates, stored as NIfTI and as DICOM series in different orders.

A ball with a bump on top (superior), a nose (anterior) and one ear (the patient's left), sampled on one
grid of LPS points; every file holds the same samples in its own storage order, with the header that
says so, so a viewer that honours the files' orientation shows the same picture from each.
"""
from __future__ import annotations

import nibabel
import numpy as np
from pydicom.dataset import Dataset, FileMetaDataset
from pydicom.uid import CTImageStorage, ExplicitVRLittleEndian, generate_uid

STEP = (2.0, 2.0, 3.0)          # mm between samples along L, P, S
HALF = (48.0, 48.0, 48.0)       # the grid spans -HALF..HALF mm: its centre is the patient's origin
BLOBS = (                        # (centre in LPS mm, radius mm)
    ((0.0, 0.0, 0.0), 30.0),     # the head
    ((0.0, 0.0, 30.0), 14.0),    # the top: superior, to 44 mm
    ((0.0, -30.0, 0.0), 12.0),   # the nose: anterior (-P), to 42 mm
    ((30.0, 0.0, 0.0), 9.0),     # the left ear: +L, to 39 mm
)
LEVEL = 500.0                   # the surface: where the stored value crosses it


def lps_axes():
    return [np.arange(-h, h + s / 2, s) for h, s in zip(HALF, STEP)]


def head_lps() -> np.ndarray:
    """(L, P, S) samples, ascending along each: 500 + 50 per mm inside the nearest blob's surface."""
    x, y, z = np.meshgrid(*lps_axes(), indexing="ij")
    inside = np.max([radius - np.sqrt((x - c[0]) ** 2 + (y - c[1]) ** 2 + (z - c[2]) ** 2)
                     for c, radius in BLOBS], axis=0)
    return np.clip(LEVEL + 50.0 * inside, 0, 1000).astype(np.float32)


def write_nifti(path, order: str = "RAS"):
    """The head as NIfTI stored RAS+ (nibabel's canonical) or LAS (radiological: i runs to the left)."""
    lps = head_lps()
    (l0, p0, s0), (sx, sy, sz) = [-h for h in HALF], STEP
    affine = np.eye(4)
    if order == "RAS":     # i -> R (= -L), j -> A (= -P): both reversed
        data, affine[:3, :3], affine[:3, 3] = lps[::-1, ::-1, :], np.diag([sx, sy, sz]), (l0, p0, s0)
    elif order == "LAS":   # i -> L: a mirror storage (negative determinant)
        data, affine[:3, :3], affine[:3, 3] = lps[:, ::-1, :], np.diag([-sx, sy, sz]), (-l0, p0, s0)
    else:
        raise ValueError(order)
    nibabel.save(nibabel.Nifti1Image(np.ascontiguousarray(data), affine), str(path))
    return path


# DICOM planes: (row direction, column direction) in LPS, i.e. ImageOrientationPatient.
PLANES = {
    "axial": ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)),      # rows run to the left, columns back: slices go up
    "coronal": ((1.0, 0.0, 0.0), (0.0, 0.0, -1.0)),   # columns down: slices go back
    "sagittal": ((0.0, 1.0, 0.0), (0.0, 0.0, -1.0)),  # rows back, columns down: slices go right
}


def write_dicom(folder, plane: str = "axial"):
    """The head as a DICOM series of `plane` slices (files written in reverse slice order)."""
    folder.mkdir(parents=True, exist_ok=True)
    lps, axes = head_lps(), lps_axes()
    row_dir, col_dir = (np.array(v) for v in PLANES[plane])
    normal = np.cross(row_dir, col_dir)
    # Which LPS array axis each DICOM direction runs along, and whether backwards.
    along = [int(np.argmax(np.abs(v))) for v in (normal, col_dir, row_dir)]
    backwards = [bool(v[a] < 0) for v, a in zip((normal, col_dir, row_dir), along)]
    stored = np.transpose(lps, along)
    stored = stored[tuple(slice(None, None, -1) if b else slice(None) for b in backwards)]
    series_uid = generate_uid()
    for k in range(stored.shape[0]):
        # The slice's first pixel: each axis's first sample in the direction the file runs along it.
        corner = np.array([axes[a][-1] if a in along and backwards[along.index(a)] else axes[a][0]
                           for a in range(3)])
        corner[along[0]] = axes[along[0]][::-1 if backwards[0] else 1][k]
        _write_slice(folder / f"IM{stored.shape[0] - k:04d}.dcm", stored[k], corner, row_dir, col_dir,
                     (STEP[along[1]], STEP[along[2]]), series_uid, k)
    return folder


def _write_slice(path, pixels, position, row_dir, col_dir, pixel_spacing, series_uid, number) -> None:
    meta = FileMetaDataset()
    meta.MediaStorageSOPClassUID = CTImageStorage
    meta.MediaStorageSOPInstanceUID = generate_uid()
    meta.TransferSyntaxUID = ExplicitVRLittleEndian
    ds = Dataset()
    ds.file_meta = meta
    ds.SOPClassUID, ds.SOPInstanceUID = CTImageStorage, meta.MediaStorageSOPInstanceUID
    ds.StudyInstanceUID, ds.SeriesInstanceUID, ds.SeriesNumber = "1.2.3", series_uid, 1
    ds.InstanceNumber = number + 1
    ds.Modality, ds.SeriesDescription = "CT", "head phantom"
    ds.Rows, ds.Columns = pixels.shape
    ds.PixelSpacing = [float(v) for v in pixel_spacing]   # between rows, between columns
    ds.ImageOrientationPatient = [float(v) for v in (*row_dir, *col_dir)]
    ds.ImagePositionPatient = [float(v) for v in position]
    ds.BitsAllocated, ds.BitsStored, ds.HighBit, ds.PixelRepresentation = 16, 16, 15, 1
    ds.SamplesPerPixel, ds.PhotometricInterpretation = 1, "MONOCHROME2"
    ds.RescaleSlope, ds.RescaleIntercept = 1.0, 0.0
    ds.PixelData = np.round(pixels).astype("<i2").tobytes()
    ds.save_as(path, enforce_file_format=True)
