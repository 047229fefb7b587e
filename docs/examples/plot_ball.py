"""
A ball, its mesh and its picture
================================

A signed distance field sampled on a grid, its isosurface as arrays (the scikit-image layout), checked
against the sphere it samples, and the same surface rendered offscreen.
"""
import matplotlib.pyplot as plt
import numpy as np

import isoscope

axis = np.linspace(-1, 1, 64)
x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
field = (0.7 - np.sqrt(x * x + y * y + z * z)).astype(np.float32)   # positive inside
spacing = (axis[1] - axis[0],) * 3

verts, faces, normals, values = isoscope.marching_cubes(field, 0.0, spacing=spacing)
radius = np.linalg.norm(verts - 1.0, axis=1)   # the grid starts at -1: vertices are from its corner
print(f"{len(faces):,} triangles; vertex distance from the centre {radius.min():.4f} .. {radius.max():.4f} "
      "(the sphere's radius is 0.7)")

image = isoscope.render(field, 0.0, spacing=spacing, size=(480, 360))
plt.imshow(image)
plt.axis("off")
plt.show()
