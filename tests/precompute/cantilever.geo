// A solid steel cantilever, 200 x 10 x 10 mm, clamped at x = 0 (tests/precompute/test_cantilever.py).
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 200, 10, 10};
// OpenCASCADE numbers a box's faces x = 0, x = L, y = 0, y = b, z = 0, z = h.
Physical Volume("part", 1) = {1};
Physical Surface("clamp", 2) = {1};
Physical Surface("free", 3) = {2, 3, 4, 5, 6};
