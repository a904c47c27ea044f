#!/usr/bin/python3
"""Makes the haptic-tool trajectories over the real lower left first molar (FDI 36, Universal 19) that
the step benchmark and the fidelity tests follow (issues #10 and #11):

  real-raster-36.csv  a raster over the occlusal surface at 20 mm/s, the haptic tip 2 mm below the
                      surface, the tool along the tooth's long axis;
  real-sweep-36.csv   fast sweeps at 100 mm/s across the central fissure, 2 mm below the surface;
  real-wedge-36.csv   the probe lowered into the embrasure between 36 and 35 (Universal 19 and 20),
                      its shank wedged between the two crowns while the hand pushes on.

Usage: scripts/trajectories/make_real_trajectories.py [DATA_DIR] [OUT_DIR]
DATA_DIR holds tooth_19.stl, tooth_20.stl (or .ply) and teeth_axes_mandible.json (default: the
repository's data/open-full-jaw/patient26, else ../shared/data/open-full-jaw/patient26); OUT_DIR
defaults to scenes/trajectories. Poses are of the tool frame (docs/tool-frame.md): origin at the tip
sphere's centre, +z toward the handle, the working end bending toward +x. Needs numpy (Debian's
python3-numpy) and nothing else; the output is deterministic.
"""
import json
import os
import struct
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SAMPLE_DT = 0.005  # s between trajectory rows (the simulator interpolates between them)


def load_mesh(path):
    """Triangles (n x 3 x 3, mm) of a binary STL or a binary little-endian PLY (vertex x y z float,
    face list uchar int)."""
    data = open(path, "rb").read()
    if path.endswith(".stl"):
        count = struct.unpack_from("<I", data, 80)[0]
        rec = np.frombuffer(data, dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]),
                            count=count, offset=84)
        return rec["v"].astype(np.float64)
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").split("\n")
    nv = next(int(l.split()[2]) for l in header if l.startswith("element vertex"))
    nf = next(int(l.split()[2]) for l in header if l.startswith("element face"))
    verts = np.frombuffer(data, dtype="<f4", count=3 * nv, offset=end).reshape(nv, 3).astype(np.float64)
    faces = np.frombuffer(data, dtype=np.dtype([("n", "u1"), ("i", "<i4", 3)]), count=nf, offset=end + 12 * nv)
    return verts[faces["i"]]


def find_data():
    for d in (os.path.join(ROOT, "data", "open-full-jaw", "patient26"),
              os.path.join(ROOT, "..", "shared", "data", "open-full-jaw", "patient26")):
        if os.path.exists(os.path.join(d, "teeth_axes_mandible.json")):
            return d
    sys.exit("make_real_trajectories: no tooth data found (give DATA_DIR)")


def mesh_file(data, number):
    for ext in (".ply", ".stl"):
        path = os.path.join(data, "tooth_%d%s" % (number, ext))
        if os.path.exists(path):
            return path
    sys.exit("make_real_trajectories: tooth_%d.ply/.stl missing in %s" % (number, data))


def tooth_frame(axes, number):
    """Centre, unit long axis (occlusal, up), a mesio-distal and a bucco-lingual unit vector."""
    a = axes[str(number)]
    c = np.array(a["c"])
    z = np.array(a["z"]) - c
    z /= np.linalg.norm(z)
    x = np.array(a["x"]) - c
    x -= x.dot(z) * z
    x /= np.linalg.norm(x)
    return c, z, x, np.cross(z, x)


def surface_heights(tris, origins, down):
    """Per ray (origin, direction `down`): distance to the first hit, or nan (Moller-Trumbore)."""
    a, e1, e2 = tris[:, 0], tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]
    p = np.cross(down, e2)
    det = np.einsum("ij,ij->i", e1, p)
    ok = np.abs(det) > 1e-12
    a, e1, e2, p, det = a[ok], e1[ok], e2[ok], p[ok], det[ok]
    out = np.full(len(origins), np.nan)
    for k, o in enumerate(origins):
        s = o - a
        u = np.einsum("ij,ij->i", s, p) / det
        q = np.cross(s, e1)
        v = (q @ down) / det
        t = np.einsum("ij,ij->i", e2, q) / det
        hit = (u >= 0) & (v >= 0) & (u + v <= 1) & (t > 0)
        if hit.any():
            out[k] = t[hit].min()
    return out


def quat_from_axes(x, y, z):
    """Unit quaternion (w, x, y, z) of the rotation whose columns are x, y, z."""
    m = np.column_stack([x, y, z])
    w = np.sqrt(max(0.0, 1.0 + m[0, 0] + m[1, 1] + m[2, 2])) / 2.0
    qx = np.copysign(np.sqrt(max(0.0, 1.0 + m[0, 0] - m[1, 1] - m[2, 2])) / 2.0, m[2, 1] - m[1, 2])
    qy = np.copysign(np.sqrt(max(0.0, 1.0 - m[0, 0] + m[1, 1] - m[2, 2])) / 2.0, m[0, 2] - m[2, 0])
    qz = np.copysign(np.sqrt(max(0.0, 1.0 - m[0, 0] - m[1, 1] + m[2, 2])) / 2.0, m[1, 0] - m[0, 1])
    q = np.array([w, qx, qy, qz])
    return q / np.linalg.norm(q)


def along_polyline(points, speed):
    """Rows (t, point) every SAMPLE_DT along a polyline travelled at `speed` (mm/s)."""
    seg = np.linalg.norm(np.diff(points, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    times = np.arange(0.0, s[-1] / speed + 1e-9, SAMPLE_DT)
    out = np.column_stack([np.interp(times * speed, s, points[:, j]) for j in range(3)])
    return times, out


def write(path, rows, q):
    with open(path, "w") as f:
        f.write("t,px,py,pz,qw,qx,qy,qz\n")
        for t, p in rows:
            f.write("%.4f,%.4f,%.4f,%.4f,%.9f,%.9f,%.9f,%.9f\n" % (t, p[0], p[1], p[2], q[0], q[1], q[2], q[3]))
    print("%s: %d rows, %.2f s" % (path, len(rows), rows[-1][0]))


def main():
    data = sys.argv[1] if len(sys.argv) > 1 else find_data()
    out_dir = sys.argv[2] if len(sys.argv) > 2 else os.path.join(ROOT, "scenes", "trajectories")
    axes = json.load(open(os.path.join(data, "teeth_axes_mandible.json")))
    tooth = load_mesh(mesh_file(data, 19))
    neighbour = load_mesh(mesh_file(data, 20))
    c, up, md, bl = tooth_frame(axes, 19)
    # Buccal is away from the arch's midline: the side of the tooth facing away from tooth 30's.
    if bl.dot(c - tooth_frame(axes, 30)[0]) < 0:
        bl = -bl
    # The tool along the long axis, tip down, the handle leaving over the buccal side.
    q_axial = quat_from_axes(bl, np.cross(up, bl), up)

    def surface_points(u, v, below):
        """Points `below` mm under the occlusal surface at crown coordinates (u along md, v along bl)."""
        origins = c + np.outer(u, md) + np.outer(v, bl) + 15.0 * up
        h = surface_heights(tooth, origins, -up)
        return origins - np.outer(h - 0.0, up) - below * up, h

    # Raster: rows along the mesio-distal axis, 1 mm apart, each clipped 0.6 mm inside the crown's
    # outline, boustrophedon, 2 mm below the surface, 20 mm/s, starting and ending 3 mm above it.
    u = np.arange(-6.0, 6.0001, 0.1)
    rows_pts = []
    for k, v0 in enumerate(np.arange(-3.5, 3.5001, 1.0)):
        pts, h = surface_points(u, np.full_like(u, v0), 2.0)
        inside = np.where(np.isfinite(h))[0]
        if len(inside) < 20:
            continue
        pts = pts[inside[6]:inside[-6] + 1]
        rows_pts.append(pts if k % 2 == 0 else pts[::-1])
    path = np.vstack(rows_pts)
    start = path[0] + 5.0 * up
    end = path[-1] + 5.0 * up
    times, pts = along_polyline(np.vstack([start, path, end]), 20.0)
    write(os.path.join(out_dir, "real-raster-36.csv"), list(zip(times + 0.5, pts)), q_axial)

    # Sweep: across the central fissure (bucco-lingual lines) at five mesio-distal stations and once
    # along it, 2 mm below the surface, 100 mm/s.
    legs = []
    for k, u0 in enumerate(np.arange(-3.0, 3.0001, 1.5)):
        v = np.arange(-3.0, 3.0001, 0.1)
        pts, h = surface_points(np.full_like(v, u0), v, 2.0)
        pts = pts[np.isfinite(h)]
        legs.append(pts if k % 2 == 0 else pts[::-1])
    u = np.arange(-4.0, 4.0001, 0.1)
    pts, h = surface_points(u, np.zeros_like(u), 2.0)
    legs.append(pts[np.isfinite(h)])
    path = np.vstack(legs)
    times, pts = along_polyline(np.vstack([path[0] + 5.0 * up, path, path[-1] + 5.0 * up]), 100.0)
    write(os.path.join(out_dir, "real-sweep-36.csv"), list(zip(times + 0.5, pts)), q_axial)

    # Wedge: the embrasure between 36 and 35, found as the midpoint of the two crowns' nearest
    # vertices; the tool tilted 20 degrees toward the buccal so the shank lies in the embrasure; the
    # hand comes down from 6 mm above to 4 mm below the contact and pushes on, then rocks mesio-distally.
    a = tooth.reshape(-1, 3)[::7]
    b = neighbour.reshape(-1, 3)[::7]
    top_a = a[a.dot(up) > np.percentile(a.dot(up), 70)]
    top_b = b[b.dot(up) > np.percentile(b.dot(up), 70)]
    d = np.linalg.norm(top_a[:, None, :] - top_b[None, :, :], axis=2)
    i, j = np.unravel_index(np.argmin(d), d.shape)
    contact = 0.5 * (top_a[i] + top_b[j])
    tilt = np.radians(20.0)
    axis = np.cos(tilt) * up + np.sin(tilt) * bl
    x_tool = np.cos(tilt) * bl - np.sin(tilt) * up
    q_wedge = quat_from_axes(x_tool, np.cross(axis, x_tool), axis)
    toward = contact - c
    toward -= toward.dot(up) * up
    toward /= np.linalg.norm(toward)
    keys = [contact + 6.0 * axis, contact, contact - 4.0 * axis, contact - 4.0 * axis + 1.0 * toward,
            contact - 4.0 * axis - 1.0 * toward, contact - 5.0 * axis, contact + 6.0 * axis]
    times, pts = along_polyline(np.array(keys), 5.0)
    write(os.path.join(out_dir, "real-wedge-36.csv"), list(zip(times + 0.5, pts)), q_wedge)


if __name__ == "__main__":
    main()
