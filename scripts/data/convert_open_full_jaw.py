#!/usr/bin/python3
"""Converts patient 26's sixteen mandibular teeth of the Open-Full-Jaw data set (Gholamalizadeh et al.
2022; licence: data/open-full-jaw/README.md and LICENSE) from binary STL to the compact binary PLY
the repository ships in data/open-full-jaw/patient26/ (issue #12).

Usage: scripts/data/convert_open_full_jaw.py [SOURCE_DIR] [OUT_DIR]
SOURCE_DIR holds tooth_17.stl ... tooth_32.stl, teeth_axes_mandible.json and, one level up, the
data set's LICENSE (default: ../shared/data/open-full-jaw/patient26 beside the checkout); OUT_DIR
defaults to the repository's data/open-full-jaw/patient26.

What it does, per tooth:
  - reads the binary STL (80-byte header, triangle count, 50 bytes per triangle; coordinates in mm);
  - welds corners whose three float32 coordinates are bit-identical into one vertex, numbered in the
    order of their first use (the STL's per-triangle normals and attribute bytes are dropped: the
    loader recomputes normals from the winding, which is kept);
  - drops triangles whose corners weld into fewer than three vertices (zero area; counted);
  - writes a binary little-endian PLY: `element vertex N` (float x, y, z in mm, exactly the STL's
    float32 values) and `element face M` (list uchar int vertex_indices), about a third of the STL.
It also re-serialises teeth_axes_mandible.json (same numbers, keys sorted, two-space indent) and copies
the data set's LICENSE text. Nothing is rounded or moved: a converted tooth has the same triangles at
the same coordinates as its STL. Needs numpy (Debian's python3-numpy) and nothing else; the output is
deterministic (same input, same bytes).
"""
import json
import os
import shutil
import struct
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TEETH = range(17, 33)  # Universal numbers of the mandibular teeth (FDI 38..31, 41..48)
STL_HEADER = 84  # bytes: 80-byte header and the 32-bit triangle count
STL_TRIANGLE = np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])  # 50 bytes


def read_stl(path):
    """Corners (n x 3 x 3 float32, mm) of a binary STL; exits naming the file if it is not one."""
    data = open(path, "rb").read()
    if len(data) < STL_HEADER:
        sys.exit("convert_open_full_jaw: %s: shorter than a binary STL header" % path)
    count = struct.unpack_from("<I", data, 80)[0]
    if count == 0 or len(data) != STL_HEADER + STL_TRIANGLE.itemsize * count:
        sys.exit("convert_open_full_jaw: %s: not a binary STL (%d bytes, %d triangles declared)"
                 % (path, len(data), count))
    rec = np.frombuffer(data, dtype=STL_TRIANGLE, count=count, offset=STL_HEADER)
    corners = np.ascontiguousarray(rec["v"])
    if not np.isfinite(corners).all():
        sys.exit("convert_open_full_jaw: %s: non-finite coordinates" % path)
    return corners


def weld(corners):
    """Shared vertices (float32, first-use order) and triangles (int32) of bit-identical corners;
    the number of degenerate triangles dropped."""
    flat = corners.reshape(-1, 3)
    keys = flat.view(np.uint32).reshape(-1, 3)  # compare the bits, so -0.0 and 0.0 stay apart
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.reshape(-1)
    # Renumber the unique vertices by their first use, so the file follows the STL's order.
    order = np.argsort(first, kind="stable")
    rank = np.empty_like(order)
    rank[order] = np.arange(order.size)
    vertices = flat[first[order]]
    faces = rank[inverse].reshape(-1, 3).astype(np.int32)
    keep = (faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2]) & (faces[:, 0] != faces[:, 2])
    faces = faces[keep]
    # Vertices used only by dropped triangles would be stray points: renumber the used ones.
    used = np.zeros(vertices.shape[0], dtype=bool)
    used[faces.reshape(-1)] = True
    remap = np.cumsum(used) - 1
    return vertices[used], remap[faces].astype(np.int32), int((~keep).sum())


def write_ply(path, vertices, faces, source_name):
    """Binary little-endian PLY with float x, y, z vertices and uchar-int face lists."""
    header = ("ply\n"
              "format binary_little_endian 1.0\n"
              "comment Open-Full-Jaw patient 26 %s (Gholamalizadeh et al. 2022), mm; licence: ../LICENSE\n"
              "comment converted by scripts/data/convert_open_full_jaw.py\n"
              "element vertex %d\n"
              "property float x\n"
              "property float y\n"
              "property float z\n"
              "element face %d\n"
              "property list uchar int vertex_indices\n"
              "end_header\n") % (source_name, vertices.shape[0], faces.shape[0])
    face_rec = np.empty(faces.shape[0], dtype=np.dtype([("n", "u1"), ("i", "<i4", 3)]))
    face_rec["n"] = 3
    face_rec["i"] = faces
    with open(path, "wb") as out:
        out.write(header.encode("ascii"))
        out.write(vertices.astype("<f4").tobytes())
        out.write(face_rec.tobytes())


def main():
    source = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
        ROOT, "..", "shared", "data", "open-full-jaw", "patient26")
    out_dir = sys.argv[2] if len(sys.argv) > 2 else os.path.join(ROOT, "data", "open-full-jaw", "patient26")
    axes_path = os.path.join(source, "teeth_axes_mandible.json")
    licence = os.path.join(os.path.dirname(os.path.normpath(source)), "LICENSE")
    for path in [os.path.join(source, "tooth_%d.stl" % n) for n in TEETH] + [axes_path, licence]:
        if not os.path.isfile(path):
            sys.exit("convert_open_full_jaw: missing %s" % path)
    os.makedirs(out_dir, exist_ok=True)

    # The meshes.
    total_in = total_out = 0
    for n in TEETH:
        stl = os.path.join(source, "tooth_%d.stl" % n)
        ply = os.path.join(out_dir, "tooth_%d.ply" % n)
        vertices, faces, dropped = weld(read_stl(stl))
        write_ply(ply, vertices, faces, "tooth_%d.stl" % n)
        total_in += os.path.getsize(stl)
        total_out += os.path.getsize(ply)
        print("tooth_%d: %d triangles, %d vertices, %d degenerate dropped, %d -> %d bytes"
              % (n, faces.shape[0], vertices.shape[0], dropped, os.path.getsize(stl), os.path.getsize(ply)))

    # The axes: the same numbers, re-serialised.
    with open(axes_path) as f:
        axes = json.load(f)
    with open(os.path.join(out_dir, "teeth_axes_mandible.json"), "w") as f:
        json.dump(axes, f, indent=2, sort_keys=True)
        f.write("\n")

    # The licence beside the folder, as the data set ships it.
    shutil.copyfile(licence, os.path.join(os.path.dirname(os.path.normpath(out_dir)), "LICENSE"))
    print("total: %d -> %d bytes" % (total_in, total_out))


if __name__ == "__main__":
    main()
