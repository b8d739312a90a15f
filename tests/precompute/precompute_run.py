"""Running modal-precompute from a test: a .prm text written into its own folder, the program run on
it with that folder as its output, and the report read back."""
import argparse
import base64
import json
import os
import re
import shutil
import struct
import subprocess
import zlib

import numpy as np


class Checks:
    """A test's named checks. Each is printed as it is made; the failed ones are listed again at the end,
    so a CI log that keeps only the output's tail still says which failed (with `detail`, what was seen)."""

    def __init__(self):
        self.failures = []

    def __call__(self, condition, what, detail=""):
        print(("ok      " if condition else "FAILED  ") + what, flush=True)
        if not condition:
            self.failures.append(what)
            if detail:
                print("   output was:", detail.strip().replace("\n", "\n   "), flush=True)
        return condition

    def below(self, name, value, limit):
        """value <= limit, printed as a table row with both."""
        passed = value <= limit
        print(f"{name:64s} {value:12.3e}  (<= {limit:.2g}) {'ok' if passed else 'FAILED'}", flush=True)
        if not passed:
            self.failures.append(f"{name}: {value:.3e} > {limit:.2g}")

    def relative(self, name, value, reference, tolerance, unit="Hz"):
        """|value - reference| / |reference| <= tolerance, both printed in the name."""
        self.below(f"{name}: {value:.3f} {unit} vs {reference:.3f}", abs(value - reference) / abs(reference), tolerance)

    @property
    def ok(self):
        return not self.failures

    def exit_code(self):
        """Lists the failed checks once more and returns the test's exit code."""
        for what in self.failures:
            print("FAILED  " + what)
        print(f"{len(self.failures)} failed")
        return 1 if self.failures else 0


def copy_meshes(source, folder):
    """The meshes and their cache keys of one run into another's folder, which then reuses them:
    gmsh does not mesh the same input twice the same, and comparing runs need one mesh."""
    os.makedirs(folder, exist_ok=True)
    for name in os.listdir(source):
        if name.endswith((".msh", ".key")):
            shutil.copy(os.path.join(source, name), folder)


def run_precompute(binary, folder, prm_text, prm_name="scene.prm", meshes_from=None, launcher=(), env=None):
    """Returns (report.json as a dict, what the program wrote to stderr); raises if it fails.
    meshes_from: a folder whose meshes to reuse; launcher: mpirun and its arguments, with env its
    environment."""
    os.makedirs(folder, exist_ok=True)
    if meshes_from:
        copy_meshes(meshes_from, folder)
    prm = os.path.join(folder, prm_name)
    with open(prm, "w") as f:
        f.write(prm_text)
    command = [*launcher, binary, prm, "--output-dir", folder, "--quiet"]
    done = subprocess.run(command, stderr=subprocess.PIPE, text=True, env=env)
    if done.returncode != 0:
        print(done.stderr[-2000:])  # the error message, which CalledProcessError does not show
        raise subprocess.CalledProcessError(done.returncode, command, stderr=done.stderr)
    with open(os.path.join(folder, "report.json")) as f:
        return json.load(f), done.stderr


HERE = os.path.dirname(os.path.abspath(__file__))


def entries_text(entries):
    """{"Section/Subsection/Entry": value} as .prm text, each entry set inside its subsections."""
    lines = []
    for path, value in entries.items():
        *sections, name = path.split("/")
        lines += [f"{'  ' * depth}subsection {section}" for depth, section in enumerate(sections)]
        lines.append(f"{'  ' * len(sections)}set {name} = {value}")
        lines += [f"{'  ' * depth}end" for depth in reversed(range(len(sections)))]
    return "\n".join(lines) + "\n"


def test_prm(prm_name, geometry=None, entries=None):
    """A .prm beside the tests, with its geometry file (beside it too) named by its path (the run writes
    the .prm into its own folder), then `entries` (entries_text) set after the file's own: the
    ParameterHandler keeps an entry's last value, so a test varies a size or a modulus over one file."""
    with open(os.path.join(HERE, prm_name)) as f:
        text = f.read()
    if geometry:
        text = text.replace(geometry, os.path.join(HERE, geometry))
    return text + ("\n" + entries_text(entries) if entries else "")


def binary_and_fresh_workdir(mpirun_help=None, required=()):
    """The arguments of a precompute test: --binary and --workdir, the latter emptied and created
    (and an optional --mpirun, when mpirun_help says what the test does with it; and the test's own
    required options, e.g. "--prm")."""
    parser = argparse.ArgumentParser()
    parser.add_argument("--binary", required=True)
    parser.add_argument("--workdir", required=True)
    for option in required:
        parser.add_argument(option, required=True)
    if mpirun_help:
        parser.add_argument("--mpirun", help=mpirun_help)
    args = parser.parse_args()
    shutil.rmtree(args.workdir, ignore_errors=True)
    os.makedirs(args.workdir)
    return args


def largest_principal_angle(a, b):
    """Between the column spaces of a and b: sin = ||(I - Qa Qa^T) Qb||_2 (accurate for tiny angles)."""
    qa, _ = np.linalg.qr(a)
    qb, _ = np.linalg.qr(b)
    return float(np.arcsin(min(1.0, np.linalg.norm(qb - qa @ (qa.T @ qb), 2))))


def validity_rates(forces):
    """A validity force is F = delta c / |c2|: where c2 is a sum that nearly cancels, F is huge and
    carries c2's round-off magnified (at np = 2, 2e-8 of the largest force, 2.8e10 N). Compared
    through its rate 1/F (0 where there is no value; 1e30, not reached, is 1e-30), whose error is
    c2's own: compared to a tolerance of the largest rate, like every other dataset."""
    f = np.asarray(forces, dtype=float)
    return np.where(f > 0, 1.0 / np.where(f > 0, f, 1.0), 0.0)


CUT_OFF_MAXIMUM = 24


def cut_off_between(frequencies, at_least=9):
    """Modes entries for a haptic cut-off midway between two frequencies at least 2 % apart, the
    at_least-th (1-based) or a later one and the next (pairs of equal modes are common on our
    symmetric parts), a floor of 4 and at most CUT_OFF_MAXIMUM modes: with at_least > 8 an eigensolver
    that seeks a count per run (ARPACK, PARPACK, LOBPCG: the floor and a margin of 4 first) needs a
    second run to decide the count."""
    k = next(k for k in range(at_least, len(frequencies)) if frequencies[k] > 1.02 * frequencies[k - 1])
    return [f"Maximum number of modes = {CUT_OFF_MAXIMUM}", "Minimum number of modes = 4", "Cut-off rule = haptic",
            f"Haptic rate = {frequencies[k - 1] + frequencies[k]:.9g}"]


def cut_off_checks(space, reference, tolerance):
    """(condition, description) pairs for a space run with cut_off_between's entries, against
    reference (the same space's lowest frequencies from a run without a cut-off): fewer modes
    computed than the maximum (the eigensolve stopped once the cut-off decided the count; before
    ARPACK and LOBPCG computed the maximum), every reference mode below the cut-off kept and no other,
    and the computed frequencies equal to the reference's (relative tolerance)."""
    computed, kept, cut_off = space["computed_frequencies_hz"], space["frequencies_hz"], space["cut_off_hz"]
    below = sum(1 for f in reference if f <= cut_off)
    compared = min(len(computed), len(reference))
    difference = max(abs(a / b - 1) for a, b in zip(computed, reference))
    name = space["name"]
    return [(len(computed) < CUT_OFF_MAXIMUM,
             f"{name}: {len(computed)} modes computed, fewer than the maximum {CUT_OFF_MAXIMUM} (the cut-off decided)"),
            (below < len(reference) and len(kept) == max(4, below),
             f"{name}: kept {len(kept)}, the {below} below the {cut_off:.1f} Hz cut-off (floor 4)"),
            (difference <= tolerance,
             f"{name}: the {compared} computed frequencies equal the reference's to {difference:.1e} <= {tolerance:g}")]


def vtu_compression_ratio(path):
    """The first data array's zlib stream against its raw size in a deal.II VTU, what 'VTU compression'
    = fast or best writes (its own base64 header: blocks, block size, last block's size, each block's
    compressed size): clearly below 1 ('none' writes appended raw data, read_vtu)."""
    text = open(path, "rb").read(1 << 16)
    start = text.index(b'format="binary">') + len(b'format="binary">')
    encoded = text[start:].lstrip()
    blocks, block_size, last_size = struct.unpack("<3I", base64.b64decode(encoded[:16]))
    header_bytes = 4 * (3 + blocks)
    header = base64.b64decode(encoded[:4 * ((header_bytes + 2) // 3)])
    compressed = sum(struct.unpack(f"<{blocks}I", header[12:header_bytes]))
    return compressed / (block_size * (blocks - 1) + last_size)


VTK_TYPES = {"Float32": "f4", "Float64": "f8", "Int32": "i4", "Int64": "i8", "UInt8": "u1", "UInt32": "u4",
             "UInt64": "u8"}


def _attributes(tag):
    return dict((k.decode(), v.decode()) for k, v in re.findall(rb'([\w:]+)="([^"]*)"', tag))


def _binary_block(encoded):
    """deal.II's format="binary" array: base64 of a UInt32 header (blocks, block size, last block's
    size, each block's zlib size), then base64 of the zlib blocks."""
    encoded = b"".join(encoded.split())
    blocks = struct.unpack("<I", base64.b64decode(encoded[:8])[:4])[0]
    header_length = 4 * ((4 * (3 + blocks) + 2) // 3)
    sizes = struct.unpack(f"<{3 + blocks}I", base64.b64decode(encoded[:header_length]))[3:]
    body, raw, at = base64.b64decode(encoded[header_length:]), b"", 0
    for size in sizes:
        raw += zlib.decompress(body[at:at + size])
        at += size
    return raw


def read_vtu(path):
    """A VTU file's arrays: {"Points", "connectivity", "offsets", "types", point data names...} ->
    numpy array (n x components where components > 1), and "_piece": NumberOfPoints and NumberOfCells.
    Reads appended raw data (format="appended", encoding="raw", header_type UInt32 or UInt64, either
    byte order), checking each array's byte count against its offset and the piece's sizes, and
    deal.II's base64 format="binary" arrays. Raises ValueError on a file that breaks the format."""
    data = open(path, "rb").read()
    head = data[:data.find(b"<AppendedData")] if b"<AppendedData" in data else data
    vtk = _attributes(re.search(rb"<VTKFile[^>]*>", head).group(0))
    order = "<" if vtk.get("byte_order", "LittleEndian") == "LittleEndian" else ">"
    count_type = np.dtype(order + VTK_TYPES[vtk.get("header_type", "UInt32")])
    piece = _attributes(re.search(rb"<Piece[^>]*>", head).group(0))
    arrays = {"_piece": {k: int(v) for k, v in piece.items()}}
    appended = None
    if b"<AppendedData" in data:
        tag = re.search(rb'<AppendedData[^>]*>\s*_', data)
        if tag is None or _attributes(tag.group(0)).get("encoding") != "raw":
            raise ValueError(f"{path}: AppendedData is not raw or lacks its '_' marker")
        appended = tag.end()
    for match in re.finditer(rb"<DataArray([^>]*?)(/>|>(.*?)</DataArray>)", head, re.S):
        attributes = _attributes(match.group(1))
        name = attributes.get("Name", "Points")
        components = int(attributes.get("NumberOfComponents", "1"))
        dtype = np.dtype(order + VTK_TYPES[attributes["type"]])
        if attributes["format"] == "appended":
            at = appended + int(attributes["offset"])
            size = int(np.frombuffer(data, count_type, 1, at)[0])
            raw = data[at + count_type.itemsize:at + count_type.itemsize + size]
            if len(raw) != size:
                raise ValueError(f"{path}: '{name}' runs past the end of the file")
        elif attributes["format"] == "binary":
            raw = _binary_block(match.group(3))
        else:
            raw = np.array(match.group(3).split(), dtype=dtype).tobytes()
        values = np.frombuffer(raw, dtype)
        arrays[name] = values.reshape(-1, components) if components > 1 else values
    if appended is not None and not re.search(rb"</AppendedData>\s*</VTKFile>\s*$", data[-64:]):
        raise ValueError(f"{path}: does not end with </AppendedData></VTKFile>")
    return arrays


def check_vtu_layout(arrays, cell_points):
    """What a reader of the VTU relies on, as (condition, words) pairs: the piece's point and cell counts
    match the arrays, the offsets are the running sums of `cell_points` per cell (a cell type -> its
    number of points), connectivity indices are points."""
    piece, types, connectivity = arrays["_piece"], arrays["types"], arrays["connectivity"].astype(np.int64)
    sizes = np.array([cell_points[int(t)] for t in types]) if len(types) else np.zeros(0, int)
    points = len(arrays["Points"])
    return [(points == piece["NumberOfPoints"], f"{points} points, the piece says {piece['NumberOfPoints']}"),
            (len(types) == piece["NumberOfCells"], f"{len(types)} cells, the piece says {piece['NumberOfCells']}"),
            (np.array_equal(arrays["offsets"], np.cumsum(sizes)), "offsets are the cells' running point counts"),
            (len(connectivity) == sizes.sum() and connectivity.min(initial=0) >= 0
             and connectivity.max(initial=-1) < points, "connectivity indexes the points"),
            (all(len(v) == points for k, v in arrays.items() if k not in
                 ("_piece", "Points", "connectivity", "offsets", "types")), "every point array has a value per point")]
