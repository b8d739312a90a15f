// A solid cylinder, radius 10 mm, length 100 mm, axis z (test_roller_cylinder.py). Lengths in mm.
SetFactory("OpenCASCADE");
Cylinder(1) = {0, 0, 0, 0, 0, 100, 10};
Physical Volume("part", 1) = {1};
// OpenCASCADE numbers a cylinder's faces: 1 the lateral (curved) face, 2 the end z = 100, 3 the end z = 0.
Physical Surface("lateral", 2) = {1};
Physical Surface("ends", 3) = {2, 3};
