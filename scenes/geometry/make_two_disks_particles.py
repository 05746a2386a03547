"""Writes two_disks_particles.csv: the particles of two_disks.msh, one per triangle at its
centroid with its area as volume (unit thickness), each disk's velocity and a material name, as
a particle file another code might export. The centroid is the triangle's shape functions at
(1/3, 1/3) summed in node order and the area the shoelace formula, the operations of Fractum's
`seeding: Elements`, so scenes/two_disks_points.ron seeds exactly the particles of
scenes/two_disks_mesh.ron.

    python3 make_two_disks_particles.py
"""

def read_msh41(path):
    lines = open(path).read().split("\n")
    physical = {}
    k = lines.index("$PhysicalNames") + 1
    for line in lines[k + 1 : k + 1 + int(lines[k])]:
        dim, tag, name = line.split(maxsplit=2)
        physical[int(tag)] = name.strip('"')
    k = lines.index("$Entities") + 1
    points, curves, surfaces, _ = (int(w) for w in lines[k].split())
    entity = {}
    for line in lines[k + 1 + points + curves : k + 1 + points + curves + surfaces]:
        w = line.split()
        count = int(w[7])
        entity[int(w[0])] = [physical[int(t)] for t in w[8 : 8 + count]]
    k = lines.index("$Nodes") + 1
    blocks = int(lines[k].split()[0])
    nodes, k = {}, k + 1
    for _ in range(blocks):
        n = int(lines[k].split()[3])
        tags = [int(t) for t in lines[k + 1 : k + 1 + n]]
        for t, line in zip(tags, lines[k + 1 + n : k + 1 + 2 * n]):
            nodes[t] = tuple(float(v) for v in line.split())
        k += 1 + 2 * n
    k = lines.index("$Elements") + 1
    blocks = int(lines[k].split()[0])
    triangles, k = [], k + 1
    for _ in range(blocks):
        dim, tag, kind, n = (int(w) for w in lines[k].split())
        if kind == 2:
            for line in lines[k + 1 : k + 1 + n]:
                triangles.append((entity[tag][0], [nodes[int(t)] for t in line.split()[1:4]]))
        k += 1 + n
    return triangles

third = 1.0 / 3.0
shape = (1.0 - third - third, third, third)
velocity = {"lower-left": (0.1, 0.1), "upper-right": (-0.1, -0.1)}
with open("two_disks_particles.csv", "w") as f:
    f.write("x,y,volume,vx,vy,material\n")
    for name, corners in read_msh41("two_disks.msh"):
        x = [0.0, 0.0]
        for k in range(3):
            for a in range(2):
                x[a] += corners[k][a] * shape[k]
        (x0, y0, _), (x1, y1, _), (x2, y2, _) = corners
        area = y0 * (x2 - x1)
        area += y1 * (x0 - x2)
        area += y2 * (x1 - x0)
        area = 0.5 * abs(area)
        vx, vy = velocity[name]
        f.write(f"{x[0]!r},{x[1]!r},{area!r},{vx!r},{vy!r},elastic\n")
