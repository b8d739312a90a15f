// A thin square plate, 100 x 100 x 1 mm (aspect ratio 100), clamped along x = 0
// (tests/precompute/test_thin_plate.py).
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 100, 100, 1};
// OpenCASCADE numbers a box's faces x = 0, x = L, y = 0, y = b, z = 0, z = h.
Physical Volume("part", 1) = {1};
Physical Surface("clamp", 2) = {1};
Physical Surface("free", 3) = {2, 3, 4, 5, 6};
