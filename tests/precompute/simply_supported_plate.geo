// NAFEMS FV52: a simply supported thick square plate, 10 x 10 x 1 m (test_simply_supported_plate.py).
// Lengths in m. Named for both supports the test uses: FV52's own (u_z = 0 along the four edges of
// the bottom face only: 'bottom_edges') and the hard simple support of the 3D reference solution
// (u_z and the tangential in-plane component zero on the side faces: 'sides_x', 'sides_y').
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 10, 10, 1};
// OpenCASCADE numbers a box's faces x-, x+, y-, y+, z-, z+.
Physical Volume("part", 1) = {1};
Physical Surface("sides_x", 2) = {1, 2};
Physical Surface("sides_y", 3) = {3, 4};
Physical Surface("bottom", 4) = {5};
Physical Surface("top", 5) = {6};
// The four edges of the bottom face z = 0.
Physical Curve("bottom_edges", 6) = Curve In BoundingBox{-1e-3, -1e-3, -1e-3, 10.001, 10.001, 1e-3};
