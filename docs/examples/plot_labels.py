"""
A label map, each label its own closed surface
==============================================

A segmentation (one integer label per voxel) gives one watertight surface per label, neighbours sharing
their vertices; each encloses its voxels' volume closely.
"""
import matplotlib.pyplot as plt
import numpy as np

import isoscope

labels = np.zeros((48, 48, 48), np.uint8)
labels[8:30, 8:30, 8:30] = 1
labels[18:40, 18:40, 20:44] = 2
labels[30:44, 6:20, 10:24] = 3

for label, (verts, faces, _normals) in isoscope.label_surfaces(labels).items():
    a, b, c = (verts[faces[:, i]] for i in range(3))
    enclosed = np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6
    print(f"label {label}: {len(faces):,} triangles, encloses {enclosed:.0f} voxels' volume "
          f"({np.count_nonzero(labels == label)} voxels)")

image = isoscope.render(labels, labels=True, size=(480, 360), azimuth=-35, elevation=25)
plt.imshow(image)
plt.axis("off")
plt.show()
