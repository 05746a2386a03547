// The 0.2 × 0.1 m plate of scenes/plate_with_hole.ron with its 10 mm hole, in quadrilaterals
// (and the few triangles recombination leaves), its ends as boundary groups: the body and the
// boundary regions of scenes/plate_with_hole_mesh.ron. The hole's edge has 128 segments.
//     gmsh -2 plate_with_hole.geo -o plate_with_hole.msh
SetFactory("OpenCASCADE");
Rectangle(1) = {0, 0, 0, 0.2, 0.1};
Disk(2) = {0.1, 0.05, 0, 0.01};
BooleanDifference{ Surface{1}; Delete; }{ Surface{2}; Delete; }
Physical Surface("plate") = {1};
Physical Curve("left") = {7};
Physical Curve("right") = {8};
Mesh.MeshSizeMax = 0.01;
MeshSize{ PointsOf{ Curve{5}; } } = 0.00049;
Mesh.RecombineAll = 1;
Mesh.Algorithm = 8;
Mesh.MshFileVersion = 4.1;
