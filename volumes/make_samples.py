"""Write the small sample files shipped in volumes/, one per format isoscope reads.

    python3 volumes/make_samples.py            # rewrites them next to this script (isoscope installed)

Each comes from a built-in field so what it should look like is known; each
exercises the format's header (spacing, 4-D frames, sidecar). Kept small: the
wheel ships them.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from isoscope.volumes import open_volume

HERE = Path(__file__).resolve().parent


def field(spec: str) -> np.ndarray:
    return open_volume(spec, backend="cpu").data


def main() -> None:
    import nibabel
    import nrrd

    # Raw like the CUDA sample's Bucky.raw: 32^3 uint8, x fastest, layout in a JSON sidecar.
    bucky = field("bucky:32")
    bucky.transpose(2, 1, 0).tofile(HERE / "bucky.raw")
    (HERE / "bucky.raw.json").write_text(json.dumps(
        {"dims": list(bucky.shape), "dtype": "uint8", "endian": "little", "spacing": [1.0, 1.0, 1.0]}) + "\n")

    # NRRD, gzip-encoded, int16 with anisotropic spacing from "space directions".
    torus = np.round(field("torus:40") * 1000).astype(np.int16)
    nrrd.write(str(HERE / "torus.nrrd"), torus, {
        "encoding": "gzip", "space": "left-posterior-superior",
        "space directions": np.diag([1.0, 1.0, 2.0]), "space origin": [0.0, 0.0, 0.0]})

    # NIfTI, gzipped, 4-D: two frames (metaballs, then the box) with 1.5 mm slices.
    frames = np.stack([field("metaballs:32"), np.float32(0.5) - field("box:32")], axis=-1)
    image = nibabel.Nifti1Image(frames.astype(np.float32), np.diag([1.0, 1.0, 1.5, 1.0]))
    image.header.set_zooms((1.0, 1.0, 1.5, 1.0))
    nibabel.save(image, str(HERE / "frames.nii.gz"))

    # numpy: a plain .npy and an .npz holding two named arrays.
    np.save(HERE / "gyroid.npy", field("gyroid:32"))
    np.savez_compressed(HERE / "shapes.npz", sphere=field("sphere:24"), torus=field("torus:24"))

    for path in sorted(HERE.iterdir()):
        if path.suffix != ".py":
            print(f"{path.name:16s} {path.stat().st_size:8d} bytes")


if __name__ == "__main__":
    main()
