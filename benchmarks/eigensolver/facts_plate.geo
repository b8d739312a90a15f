// The part of FACTS.md's eigensolver measurements: a plate 200 x 100 x 5 mm with two ribs 3 mm thick
// and 20 mm high along x, clamped at x = 0. The scenes in this folder grade the mesh down around the
// middle of one rib.
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 200, 100, 5};
Box(2) = {0, 28.5, 5, 200, 3, 20};
Box(3) = {0, 68.5, 5, 200, 3, 20};
BooleanUnion(4) = { Volume{1}; Delete; }{ Volume{2, 3}; Delete; };
clamp() = Surface In BoundingBox{-0.1, -0.1, -0.1, 0.1, 100.1, 25.1};
free() = Abs(Boundary{ Volume{4}; });
free() -= clamp();
Physical Volume("part", 1) = {4};
Physical Surface("clamp", 2) = {clamp()};
Physical Surface("free", 3) = {free()};
