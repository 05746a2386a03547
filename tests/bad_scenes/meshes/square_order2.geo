// The square of square.geo in second-order (6-node) triangles, which bodies do not take.
SetFactory("OpenCASCADE");
Rectangle(1) = {0, 0, 0, 0.1, 0.1};
Mesh.MeshSizeMin = 0.05;
Mesh.MeshSizeMax = 0.05;
Mesh.ElementOrder = 2;
Mesh.MshFileVersion = 4.1;
