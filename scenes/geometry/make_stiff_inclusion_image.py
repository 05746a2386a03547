"""Writes stiff_inclusion.png, a synthetic CT slice of the specimen of stiff_inclusion.ron: an
epoxy plate 0.2 m by 0.1 m with a steel disk of radius 0.02 m at (0.1, 0.05), one pixel per
2.5 mm grid cell. Like a scan, each phase's grey values scatter about its level (epoxy about 100,
steel about 230); the scene's grey windows threshold them back into the two phases.

    python3 -m venv venv && venv/bin/pip install numpy pillow
    venv/bin/python make_stiff_inclusion_image.py

A pixel is steel when its centre lies in the disk, tested with the arithmetic of Fractum's
`Disk`, so that one particle per pixel gives the particles of the built-in twin with one
particle per cell. Rows are written top row first: row r holds y = (rows - 1 - r + 0.5) * h.
"""
import os

import numpy as np
from PIL import Image

H = 0.0025
COLUMNS, ROWS = 80, 40

x = ((np.arange(COLUMNS) + 0.5) * H)[None, :]
y = ((np.arange(ROWS)[::-1] + 0.5) * H)[:, None]
dx, dy = x - 0.1, y - 0.05
steel = dx * dx + dy * dy <= 0.02 * 0.02
noise = np.random.default_rng(1994).integers(-15, 16, size=(ROWS, COLUMNS))
grey = np.where(steel, 230, 100) + noise
Image.fromarray(grey.astype(np.uint8), mode="L").save(
    os.path.join(os.path.dirname(os.path.abspath(__file__)), "stiff_inclusion.png")
)
