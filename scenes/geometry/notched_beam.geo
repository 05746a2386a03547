// The drop-weight test's notched concrete beam, 0.42 × 0.1 × 0.1 m with a 10 mm wide notch
// 50 mm deep at mid-span, in tetrahedra: the beam of scenes/drop_weight_3d_mesh.ron.
//     gmsh -3 notched_beam.geo -o notched_beam.msh
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 0.42, 0.1, 0.1};
Box(2) = {0.205, 0, 0, 0.01, 0.05, 0.1};
BooleanDifference{ Volume{1}; Delete; }{ Volume{2}; Delete; }
Physical Volume("beam") = {1};
Mesh.MeshSizeMax = 0.05;
Mesh.MshFileVersion = 4.1;
