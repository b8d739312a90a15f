"""An independent reader of the .mrt basis file (docs/basis-format.md), for tests and studies.

It checks what the kernel's loader checks (magic, version, sizes, CRCs, alignment) and returns the
sections as numpy arrays keyed by (kind, space, source_space)."""
import struct
import zlib

import numpy as np

SCENE_WIDE = 0xFFFFFFFF
DTYPES = {1: np.dtype("<u4"), 2: np.dtype("<f4"), 3: np.dtype("<f8"), 4: np.dtype("u1")}
KIND_NAMES = {
    1: "DISPLAY_VERTICES", 2: "DISPLAY_TRIANGLES", 3: "DISPLAY_REGION", 4: "PATCH_OFFSETS",
    5: "PATCH_VERTICES", 6: "PATCH_WEIGHTS", 7: "SCENE_SCALARS", 16: "SPACE_INFO", 17: "SPACE_NAME",
    18: "EIGENVALUES", 19: "DAMPING_RATIOS", 20: "DISPLAY_MODES", 21: "CANDIDATE_VERTICES",
    22: "CANDIDATE_MODES", 23: "CANDIDATE_COMPLIANCE", 24: "CROSS_COMPLIANCE", 25: "PARTICIPATION",
    26: "VALIDATION_CASES", 27: "VALIDATION_RESPONSE", 28: "CROSS_OFFSETS", 29: "CROSS_NEIGHBOURS",
    30: "CROSS_BLOCKS", 31: "FELT_STIFFNESS", 32: "TRANSFER", 33: "VALIDITY_FORCE", 34: "FAR_COMPLIANCE",
}


class BasisFileError(ValueError):
    pass


def read(path):
    data = open(path, "rb").read()
    if len(data) < 64 or data[:8] != b"MODALRT\0":
        raise BasisFileError(f"{path}: bad magic")
    (major, minor, header_bytes, count, file_bytes, n_spaces, nv, nt, max_modes, max_patch, mode_type,
     table_crc, header_crc) = struct.unpack_from("<IIIIQIIIIIIII", data, 8)
    if major != 1:
        raise BasisFileError(f"{path}: version {major}.{minor} is not 1.x")
    if zlib.crc32(data[:60]) != header_crc:
        raise BasisFileError(f"{path}: header checksum mismatch")
    if file_bytes != len(data):
        raise BasisFileError(f"{path}: truncated ({len(data)} of {file_bytes} bytes)")
    table = data[header_bytes:header_bytes + 40 * count]
    if zlib.crc32(table) != table_crc:
        raise BasisFileError(f"{path}: section table checksum mismatch")
    sections = {}
    for k in range(count):
        kind, space, source, stype, offset, n, crc, _ = struct.unpack_from("<IIIIQQII", table, 40 * k)
        dtype = DTYPES[stype]
        end = offset + n * dtype.itemsize
        if offset % 64 or end > len(data):
            raise BasisFileError(f"{path}: section {KIND_NAMES.get(kind, kind)} out of bounds or misaligned")
        raw = data[offset:end]
        if zlib.crc32(raw) != crc:
            raise BasisFileError(f"{path}: section {KIND_NAMES.get(kind, kind)} checksum mismatch")
        sections[(kind, space, source)] = np.frombuffer(raw, dtype=dtype)
    header = dict(n_spaces=n_spaces, n_display_vertices=nv, n_display_triangles=nt, max_modes=max_modes,
                  max_patch_size=max_patch, mode_scalar_type=mode_type, version=(major, minor))
    return header, sections
