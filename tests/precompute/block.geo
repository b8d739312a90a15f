// A block 40 x 40 x 10 mm clamped on its bottom face, pressed on its top (test_patch_convergence.py).
SetFactory("OpenCASCADE");
Box(1) = {-20, -20, 0, 40, 40, 10};
// OpenCASCADE numbers a box's faces x-, x+, y-, y+, z-, z+.
Physical Volume("part", 1) = {1};
Physical Surface("clamp", 2) = {5};
Physical Surface("free", 3) = {1, 2, 3, 4, 6};
