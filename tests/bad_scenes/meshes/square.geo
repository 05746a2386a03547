// A unit square in a few triangles: the source of the bad meshes here (make_bad_meshes.py).
SetFactory("OpenCASCADE");
Rectangle(1) = {0, 0, 0, 0.1, 0.1};
Physical Surface("square") = {1};
Mesh.MeshSizeMin = 0.05;
Mesh.MeshSizeMax = 0.05;
Mesh.MshFileVersion = 4.1;
