#!/usr/bin/env python3
"""The cracks of a Charpy run (`scenes/charpy_dfg.ron` or a refinement of it) at its last frame:
for each row of the ligament's particles, where they stood at the first frame, the damage of
every damaged particle along it; then the cracks' width summed over the ligament,

    W = sum over ligament particles of D * A / L,

(A each particle's area, L = 8 mm the ligament's height), to set beside l_ch: the law is built so
that a band l_ch wide, stretched to full failure, spends G_f per unit area of crack.

Standard library only. Usage: charpy_bands.py RUN_DIR
"""
import sys
from collections import defaultdict

from vtu_frames import frames, read_frame

LIGAMENT = (2.0e-3, 10.0e-3)  # the ligament's rows lie between the notch's tip and the top face
STRIKER = 3  # the striker is the scene's fourth body


def main():
    if len(sys.argv) != 2:
        print(__doc__.split("\n\n")[-1].strip(), file=sys.stderr)
        return 2
    run = frames(sys.argv[1])
    first = read_frame(run[0][1], {"id", "Points", "volume"})
    last = read_frame(run[-1][1], {"id", "body", "damage"})
    thickness = read_frame(run[0][1], {"thickness"})["thickness"][0]
    start = {
        pid: (first["Points"][3 * i], first["Points"][3 * i + 1], first["volume"][i] / thickness)
        for i, pid in enumerate(first["id"])
    }
    rows, width, failed = defaultdict(list), 0.0, 0
    for i, pid in enumerate(last["id"]):
        x, y, area = start[pid]
        damage = last["damage"][i]
        if last["body"][i] == STRIKER or not LIGAMENT[0] < y < LIGAMENT[1] or damage <= 0.0:
            continue
        rows[round(y * 1e6)].append((x, damage))
        width += damage * area / (LIGAMENT[1] - LIGAMENT[0])
        failed += damage >= 0.5
    print("at t = %.1f µs; damage along each row (x in mm)" % (run[-1][0] * 1e6))
    for key in sorted(rows):
        cells = " ".join("%.2f@%+.2f" % (d, x * 1e3) for x, d in sorted(rows[key]))
        print("y = %5.2f mm: %s" % (key / 1e3, cells))
    print("particles damaged %d, at least half %d" % (sum(map(len, rows.values())), failed))
    print("W = %.3f mm" % (width * 1e3))
    return 0


if __name__ == "__main__":
    sys.exit(main())
