// The source of bracket.step (written by: gmsh bracket.geo -0 -o bracket.step), the README's second example.
// An L-bracket in mm: a 60 x 40 x 4 base with two 6 mm bolt holes, a 60 x 4 x 36 upright flange.
SetFactory("OpenCASCADE");
Box(1) = {0, 0, 0, 60, 40, 4};
Box(2) = {0, 36, 4, 60, 4, 36};
Cylinder(3) = {15, 18, -1, 0, 0, 6, 3};
Cylinder(4) = {45, 18, -1, 0, 0, 6, 3};
BooleanDifference{ Volume{1}; Delete; }{ Volume{3, 4}; Delete; }
BooleanUnion{ Volume{1}; Delete; }{ Volume{2}; Delete; }
