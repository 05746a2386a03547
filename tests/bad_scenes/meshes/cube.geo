// A cube in a few tetrahedra: the source of inverted.msh (make_bad_meshes.py).
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 0.1, 0.1, 0.1};
Mesh.MeshSizeMin = 0.1;
Mesh.MeshSizeMax = 0.1;
Mesh.MshFileVersion = 4.1;
