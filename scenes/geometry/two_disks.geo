// Two disks of radius 0.2 about (0.2, 0.2) and (0.8, 0.8), in triangles, each its own
// physical group: the bodies of scenes/two_disks_mesh.ron.
//     gmsh -2 two_disks.geo -o two_disks.msh
SetFactory("OpenCASCADE");
Disk(1) = {0.2, 0.2, 0, 0.2};
Disk(2) = {0.8, 0.8, 0, 0.2};
Physical Surface("lower-left") = {1};
Physical Surface("upper-right") = {2};
Mesh.MeshSizeMin = 0.025;
Mesh.MeshSizeMax = 0.025;
Mesh.MshFileVersion = 4.1;
