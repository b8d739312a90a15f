#!/usr/bin/python3
"""The VTU files as ParaView reads them (docs/precompute.md, the outputs): on the cantilever
(tests/precompute/cantilever.prm, P2, 4 mode shapes), run once with the defaults and once with
'Output/VTU compression = fast' on the same meshes (copied: gmsh is not bit-reproducible).

* by default every VTU (modes_global.vtu, felt_stiffness.vtu, validity.vtu) is VTK XML with its arrays
  appended raw: header_type UInt64, the '_' marker, each DataArray's offset at its byte count, the
  counts chaining to </AppendedData></VTKFile>, the piece's point and cell counts those of the arrays;
* the mode-shape file holds exactly what deal.II's writer puts in the compressed one: the same cells
  (offsets, types), and, through its connectivity, the same points and the same value of every field
  at every cell's node; its points shared between cells, it has fewer than a fifth of the other's;
* the display-surface maps have a value per display vertex, the felt stiffness finite and positive;
* where VTK's Python module is installed (Debian's python3-vtk9: ParaView's reader), VTK reads every
  file without an error to the same points, cells and arrays (skipped, and said so, without it).
Python standard library and numpy; VTK only for that last check."""
import os
import re
import shutil
import subprocess
import sys

import numpy as np

from precompute_run import Checks, binary_and_fresh_workdir, check_vtu_layout, copy_meshes, read_vtu

HERE = os.path.dirname(os.path.abspath(__file__))
TET_POINTS = {10: 4, 24: 10}  # VTK_TETRA, VTK_QUADRATIC_TETRA
TRIANGLE_POINTS = {5: 3}
check = Checks()


def run(args, folder, extra=""):
    with open(os.path.join(folder, "cantilever.prm"), "w") as f:
        f.write(open(os.path.join(HERE, "cantilever.prm")).read() + extra)
    shutil.copy(os.path.join(HERE, "cantilever.geo"), folder)
    done = subprocess.run([args.binary, os.path.join(folder, "cantilever.prm"), "--output-dir", folder, "--quiet"],
                          capture_output=True, text=True)
    check(done.returncode == 0, f"the cantilever runs in {os.path.basename(folder)}", done.stdout + done.stderr)


def appended_raw(path):
    """What the XML says of the appended block: raw, UInt64 byte counts, every array appended."""
    head = open(path, "rb").read(4096).split(b"<AppendedData")[0]
    return (b'header_type="UInt64"' in head and b'<AppendedData encoding="raw">' in open(path, "rb").read()
            and not re.search(rb'format="(ascii|binary)"', head))


def layout(path, cell_points):
    try:
        arrays = read_vtu(path)
    except ValueError as error:
        check(False, f"{os.path.basename(path)} reads", str(error))
        return None
    read_by_vtk(path, arrays)
    check(appended_raw(path), f"{os.path.basename(path)}: arrays appended raw, UInt64 byte counts")
    for condition, words in check_vtu_layout(arrays, cell_points):
        check(condition, f"{os.path.basename(path)}: {words}")
    return arrays


def read_by_vtk(path, ours):
    """VTK's own reader (ParaView's) on the file, against read_vtu's arrays; skipped without VTK."""
    try:
        import vtk
        from vtk.util.numpy_support import vtk_to_numpy
    except ImportError:
        print(f"skipped VTK's reader on {os.path.basename(path)}: no python3-vtk9 here")
        return
    reader = vtk.vtkXMLUnstructuredGridReader()
    reader.SetFileName(path)
    reader.Update()
    grid, data = reader.GetOutput(), reader.GetOutput().GetPointData()
    arrays = {data.GetArray(i).GetName(): vtk_to_numpy(data.GetArray(i)) for i in range(data.GetNumberOfArrays())}
    check(reader.GetErrorCode() == 0 and grid.GetNumberOfCells() == ours["_piece"]["NumberOfCells"]
          and np.array_equal(vtk_to_numpy(grid.GetPoints().GetData()), ours["Points"])
          and np.array_equal(vtk_to_numpy(grid.GetCells().GetConnectivityArray()), ours["connectivity"])
          and arrays.keys() == {k for k in ours if k not in ("_piece", "Points", "connectivity", "offsets", "types")}
          and all(np.array_equal(v, ours[k]) for k, v in arrays.items()),
          f"VTK's reader reads {os.path.basename(path)} to the same points, cells and arrays")


def same_as_deal_ii(ours, theirs):
    """Our shared points, expanded through the connectivity, against deal.II's points of each cell."""
    check(ours.keys() == theirs.keys(), "the mode-shape files name the same arrays", f"{ours.keys()} {theirs.keys()}")
    for name in ("offsets", "types"):
        check(np.array_equal(ours[name], theirs[name]), f"the same cells: {name}")
    each_cell = ours["connectivity"].astype(np.int64)
    check(np.array_equal(theirs["connectivity"], np.arange(len(theirs["connectivity"]))),
          "deal.II's file gives every cell its own points")
    fields = [k for k in ours if k not in ("_piece", "connectivity", "offsets", "types")]
    differing = [k for k in fields if not np.array_equal(ours[k][each_cell], theirs[k])]
    check(not differing, f"the same points and values at every cell's node in {len(fields)} arrays", str(differing))
    shared, own = ours["_piece"]["NumberOfPoints"], theirs["_piece"]["NumberOfPoints"]
    check(5 * shared < own, f"points shared between cells: {shared} against deal.II's {own}")


def main():
    args = binary_and_fresh_workdir()
    default, compressed = (os.path.join(args.workdir, name) for name in ("default", "compressed"))
    os.makedirs(default)
    run(args, default)
    modes = layout(os.path.join(default, "modes_global.vtu"), TET_POINTS)
    vertices = None
    for name in ("felt_stiffness.vtu", "validity.vtu"):
        arrays = layout(os.path.join(default, name), TRIANGLE_POINTS)
        if arrays and name == "felt_stiffness.vtu":
            vertices = arrays["_piece"]["NumberOfPoints"]
            felt = arrays["felt stiffness global [N/mm]"]
            check(np.all(np.isfinite(felt)) and felt.max() > 0, "the felt stiffness is finite, positive somewhere")
        elif arrays:
            check(arrays["_piece"]["NumberOfPoints"] == vertices, "both maps on the same display surface")

    copy_meshes(default, compressed)
    run(args, compressed, "subsection Output\n  set VTU compression = fast\nend\n")
    theirs = read_vtu(os.path.join(compressed, "modes_global.vtu"))
    check(b'format="binary"' in open(os.path.join(compressed, "modes_global.vtu"), "rb").read(4096),
          "'VTU compression = fast' writes deal.II's zlib-compressed base64")
    if modes:
        same_as_deal_ii(modes, theirs)
    sizes = {folder: os.path.getsize(os.path.join(folder, "modes_global.vtu")) for folder in (default, compressed)}
    print(f"modes_global.vtu: {sizes[default]} B appended raw, {sizes[compressed]} B deal.II's compressed")
    return check.exit_code()


if __name__ == "__main__":
    sys.exit(main())
