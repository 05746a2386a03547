"""Writes the bad images of the bad-scene corpus (tests/bad_scenes/image_*.ron).

    python3 -m venv venv && venv/bin/pip install numpy pillow tifffile
    venv/bin/python make_bad_images.py
"""
import io
import os

import numpy as np
import tifffile
from PIL import Image

HERE = os.path.dirname(os.path.abspath(__file__))
grey = np.arange(16, dtype=np.uint8).reshape(4, 4)

# Grey values 0 to 15: no voxel falls in a window of 200 to 255.
Image.fromarray(grey, mode="L").save(os.path.join(HERE, "dark.png"))

# A PNG cut off halfway through.
buffer = io.BytesIO()
Image.fromarray(np.tile(grey, (8, 8)), mode="L").save(buffer, format="PNG")
data = buffer.getvalue()
with open(os.path.join(HERE, "truncated.png"), "wb") as f:
    f.write(data[: len(data) // 2])

# A colour picture.
Image.fromarray(np.stack([grey] * 3, axis=-1), mode="RGB").save(os.path.join(HERE, "colour.png"))

# A stack whose second page is wider than its first.
with tifffile.TiffWriter(os.path.join(HERE, "pages_differ.tif")) as tif:
    tif.write(grey, photometric="minisblack")
    tif.write(np.zeros((4, 5), dtype=np.uint8), photometric="minisblack")

# Numbered slices with slice 2 missing.
folder = os.path.join(HERE, "gap")
os.makedirs(folder, exist_ok=True)
for k in (0, 1, 3):
    Image.fromarray(grey, mode="L").save(os.path.join(folder, f"slice_{k:02d}.png"))
