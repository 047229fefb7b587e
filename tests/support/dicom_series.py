"""Real DICOM series for the tests, written with pydicom: a CT-like ball in oblique slices."""
from __future__ import annotations

import random

import numpy as np
from pydicom.dataset import Dataset, FileMetaDataset
from pydicom.encaps import encapsulate
from pydicom.uid import CTImageStorage, ExplicitVRLittleEndian, generate_uid

ROW_DIR = np.array([np.cos(0.3), np.sin(0.3), 0.0])                                 # oblique, in plane
COL_DIR = np.array([-np.sin(0.3) * np.cos(0.2), np.cos(0.3) * np.cos(0.2), np.sin(0.2)])
NORMAL = np.cross(ROW_DIR, COL_DIR)


def write_series(folder, stored, *, step=2.5, pixel_spacing=(0.8, 0.6), origin=(-40.0, 12.0, 100.0),
                 intercept=-1024.0, slope=1.0, series_uid=None, number=1, positions=None,
                 transfer_syntax=ExplicitVRLittleEndian, description="test CT"):
    """One file per slice, in shuffled file names; slice k sits at origin + k * step * normal."""
    folder.mkdir(parents=True, exist_ok=True)
    series_uid = series_uid or generate_uid()
    names = [f"IM{n:04d}.dcm" for n in random.Random(number).sample(range(1000), len(stored))]
    for k, pixels in enumerate(stored):
        meta = FileMetaDataset()
        meta.MediaStorageSOPClassUID = CTImageStorage
        meta.MediaStorageSOPInstanceUID = generate_uid()
        meta.TransferSyntaxUID = transfer_syntax
        ds = Dataset()
        ds.file_meta = meta
        ds.SOPClassUID, ds.SOPInstanceUID = CTImageStorage, meta.MediaStorageSOPInstanceUID
        ds.StudyInstanceUID, ds.SeriesInstanceUID, ds.SeriesNumber = "1.2.3", series_uid, number
        ds.Modality, ds.SeriesDescription = "CT", description
        ds.Rows, ds.Columns = pixels.shape
        ds.PixelSpacing = list(pixel_spacing)
        ds.ImageOrientationPatient = [*ROW_DIR, *COL_DIR]
        position = positions[k] if positions is not None else np.array(origin) + k * step * NORMAL
        ds.ImagePositionPatient = [float(v) for v in position]
        ds.BitsAllocated, ds.BitsStored, ds.HighBit, ds.PixelRepresentation = 16, 16, 15, 1
        ds.SamplesPerPixel, ds.PhotometricInterpretation = 1, "MONOCHROME2"
        ds.RescaleSlope, ds.RescaleIntercept = slope, intercept
        if transfer_syntax == ExplicitVRLittleEndian:
            ds.PixelData = pixels.astype("<i2").tobytes()
        else:  # compressed: bytes no decoder here understands
            ds.PixelData = encapsulate([b"\xff\xd8" + bytes(30)])
            ds["PixelData"].VR = "OB"
        ds.save_as(folder / names[k], enforce_file_format=True)
    (folder / "notes.txt").write_text("not DICOM: skipped")
    return series_uid


def ct_ball(slices=12, rows=20, cols=24):
    """Stored values of a CT-like ball: 1024 + HU, air (-1000 HU) outside, bone-ish (+500) inside."""
    k, r, c = np.mgrid[:slices, :rows, :cols]
    distance = np.sqrt(((k - 5.5) * 2.5) ** 2 + ((r - 9.5) * 0.8) ** 2 + ((c - 11.5) * 0.6) ** 2)
    return np.where(distance < 9.0, 1524, 24).astype(np.int16)
