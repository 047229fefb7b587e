"""
Two surfaces, one inside the other
==================================

Several levels at once, the outer one translucent (order-independent blending), as ``isoscope render
--iso A --iso B --opacity 0.35,1`` draws them: a scan's skin over its bone, here two nested blobs.
"""
import matplotlib.pyplot as plt
import numpy as np

import isoscope

axis = np.linspace(-1, 1, 72)
x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
density = np.exp(-3 * (x * x + 1.6 * y * y + z * z)) + 0.6 * np.exp(-20 * ((x - 0.2) ** 2 + y * y + z * z))

image = isoscope.render(density, [0.3, 0.8], opacities=[0.35, 1.0], size=(480, 360), azimuth=-50, elevation=20)
plt.imshow(image)
plt.axis("off")
plt.show()
