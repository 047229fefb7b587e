"""
Looking inside: a slice and a clip plane
========================================

A slice through the volume (its values through a colour map, the surface's isocurve on it) and a clip
plane that hides half the surface and caps the cut, as ``--slice z=32 --clip x=32`` give on the command line.
"""
import matplotlib.pyplot as plt
import numpy as np

import isoscope

axis = np.linspace(-1, 1, 64)
x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
gyroid = (np.sin(4 * x) * np.cos(4 * y) + np.sin(4 * y) * np.cos(4 * z) + np.sin(4 * z) * np.cos(4 * x)).astype(
    np.float32)

image = isoscope.render(gyroid, 0.0, size=(480, 360), slices=[("z", 32)], clip=("x", 32))
plt.imshow(image)
plt.axis("off")
plt.show()
