"""
The volume itself: a bright core no surface shows
=================================================

A dim blob with a bright core inside it.  The surface at a level between the two is the blob's outside
and hides the core; the maximum intensity projection (``raycast="mip"``) shows it through the blob, and
emission-absorption rendering (``raycast="dvr"``) shows both, the core glowing through the haze.
"""
import matplotlib.pyplot as plt
import numpy as np

import isoscope

axis = np.linspace(-1, 1, 64)
x, y, z = np.meshgrid(axis, axis, axis, indexing="ij")
volume = (0.4 * np.exp(-3 * (x * x + y * y + z * z))
          + 0.6 * np.exp(-40 * ((x - 0.25) ** 2 + y * y + (z + 0.1) ** 2))).astype(np.float32)

pictures = {"surface at 0.2": isoscope.render(volume, 0.2, size=(320, 240)),
            "mip": isoscope.render(volume, 0.2, size=(320, 240), raycast="mip"),
            "dvr": isoscope.render(volume, 0.2, size=(320, 240), raycast="dvr")}
figure, axes = plt.subplots(1, 3, figsize=(12, 3.2))
for axis_, (title, image) in zip(axes, pictures.items()):
    axis_.imshow(image)
    axis_.set_title(title)
    axis_.axis("off")
plt.show()
