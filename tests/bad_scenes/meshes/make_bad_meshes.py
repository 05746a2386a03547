"""Writes the bad meshes of the corpus from the good ones Gmsh wrote here:

    gmsh -2 square.geo -o square.msh
    gmsh square.msh -save -bin -format msh41 -o square_binary.msh
    gmsh -3 cube.geo -o cube.msh
    gmsh -2 square_order2.geo -o second_order.msh     (6-node triangles: an unknown type)
    python3 make_bad_meshes.py

Each bad mesh holds one mistake.
"""

def lines(name):
    return open(name).read().split("\n")

def write(name, text):
    with open(name, "w") as f:
        f.write(text)

square = lines("square.msh")
nodes = square.index("$Nodes")

# The file ends inside $Nodes, in the middle of a coordinate line.
write("truncated.msh", "\n".join(square[: nodes + 13]) + "\n0 0.1")

# The $Nodes header counts one node more than its blocks hold.
header = square[nodes + 1].split()
header[1] = str(int(header[1]) + 1)
wrong = square[:]
wrong[nodes + 1] = " ".join(header)
write("wrong_count.msh", "\n".join(wrong))

# A node's x is not a number.
nan = square[:]
k = nan.index("0.05000000000000004 0 0")
nan[k] = "nan 0 0"
write("nan_node.msh", "\n".join(nan))

# The binary twin cut short inside its $Elements section.
binary = open("square_binary.msh", "rb").read()
cut = binary.index(b"$Elements") + 60
open("truncated_binary.msh", "wb").write(binary[:cut])

# One tetrahedron of the cube with two nodes swapped: turned inside out. The $Elements
# section is walked block by block (`dim tag type count`, then `count` element lines).
cube = lines("cube.msh")
k = cube.index("$Elements") + 2
while True:
    dim, tag, kind, count = (int(w) for w in cube[k].split())
    if kind == 4:  # 4-node tetrahedra
        break
    k += count + 1
third = cube[k + 3].split()
third[1], third[2] = third[2], third[1]
cube[k + 3] = " ".join(third) + " "
write("inverted.msh", "\n".join(cube))
