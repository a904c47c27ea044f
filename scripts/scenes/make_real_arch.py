#!/usr/bin/python3
"""Writes the built-in scene scenes/real-arch.yaml (issue #12): patient 26's sixteen scanned lower
teeth (data/open-full-jaw/patient26, Open-Full-Jaw) in their scanned positions, a gingiva band along
their cervical lines, a tongue inside the arch and the paper's three lesions (two on 46, one on 36).

Usage: scripts/scenes/make_real_arch.py [OUT]   (default: scenes/real-arch.yaml)
Needs numpy (Debian's python3-numpy) and nothing else; the output is deterministic.

What it computes, from the meshes and teeth_axes_mandible.json (centre c of each crown and its long
axis z, which points occlusally; the data set's "mesial" axis x points distally on these teeth, which
the script checks against the neighbours):
  - each tooth's cemento-enamel junction (CEJ) on its long axis: its highest point along z minus the
    anatomical crown height of its type (mandibular teeth, Wheeler's table: incisors 9.0 / 9.5 mm,
    canine 11.0, premolars 8.5 / 8.0, molars 7.5 / 7.0 / 7.0 mm). The third molars have no axes in the
    data set: they take their neighbour's axis and their crown's centre;
  - the world frame of the other built-in scenes: origin midway between the CEJs of 46 and 36, z the
    normal of the plane through the sixteen cusp tips (occlusal, up), x toward the patient's left
    (from 46 to 36), y toward the back. Every tooth gets this one pose: the scan's relative positions
    are kept exactly;
  - the gingiva band's path through the sixteen CEJs, 1 mm above them (its rounded top meets a molar's
    buccal and lingual faces about at the CEJ), 18 mm deep so that it covers every root;
  - the tongue inside the arch, clear of every tooth;
  - the lesions: #1 in 46's central fossa and #3 along 36's central fissure, both placed on the long
    axis above the crown and snapped down; #2 on 46's mesial surface 1.5 mm cervical to the contact
    with 45 (the closest pair of points of the two scans), with the scan's outward normal there.
"""
import json
import math
import os
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
DATA = os.path.join(ROOT, "data", "open-full-jaw", "patient26")
DATA_REF = "data:open-full-jaw/patient26"  # how the scene names the folder (docs/scene-format.md)

# Universal number -> FDI number, in arch order from the patient's right third molar to the left one.
ARCH = [32, 31, 30, 29, 28, 27, 26, 25, 24, 23, 22, 21, 20, 19, 18, 17]
FDI = {n: (38 - (n - 17) if n <= 24 else 41 + (n - 25)) for n in range(17, 33)}
# Anatomical crown heights (mm) of the mandibular teeth by FDI tooth position (1 = central incisor).
CROWN_HEIGHT = {1: 9.0, 2: 9.5, 3: 11.0, 4: 8.5, 5: 8.0, 6: 7.5, 7: 7.0, 8: 7.0}
# The posterior teeth, where the diagnosis study draws its lesions (scripts/studies/diagnosis_sites.py:
# 34-37, 44-47), get the fine trees (0.015 mm), the others coarser ones (0.05 mm), the soft gingiva
# 0.08 mm. A premolar's coarse tree tilted the contact normals 16-23 degrees, beyond what force
# shading turns (docs/step.md): frictionless enamel on 44 rippled 0.3 N, twice 46's unshaded ripple.
FINE = {34, 35, 36, 37, 44, 45, 46, 47}
GUM_ABOVE_CEJ = 1.0  # mm, path height above the CEJ
GUM_WIDTH = 16.0  # mm
GUM_HEIGHT = 18.0  # mm
TONGUE = {"length": 46.0, "width": 30.0, "height": 14.0}  # mm
TONGUE_TOP_ABOVE_CEJ = 4.0  # mm, the tongue's top above the molars' CEJ plane
CONTACT_TO_LESION = 1.5  # mm, lesion #2 below the 45-46 contact along 46's long axis


def load_ply(path):
    """Vertices (n x 3, mm) and triangles (m x 3) of a binary PLY written by convert_open_full_jaw.py."""
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    header = data[:end].decode("ascii").split("\n")
    nv = next(int(l.split()[2]) for l in header if l.startswith("element vertex"))
    nf = next(int(l.split()[2]) for l in header if l.startswith("element face"))
    verts = np.frombuffer(data, dtype="<f4", count=3 * nv, offset=end).reshape(nv, 3).astype(np.float64)
    faces = np.frombuffer(data, dtype=np.dtype([("n", "u1"), ("i", "<i4", 3)]), count=nf, offset=end + 12 * nv)
    return verts, faces["i"].astype(np.int64)


def unit(v):
    return v / np.linalg.norm(v)


def tooth_frames(meshes, axes):
    """Per Universal number: centre c, long axis z (occlusal), distal axis x, highest point along z."""
    frames = {}
    for n in ARCH:
        if str(n) not in axes:
            continue
        a = axes[str(n)]
        c = np.array(a["c"])
        z = unit(np.array(a["z"]) - c)
        x = np.array(a["x"]) - c
        x = unit(x - x.dot(z) * z)
        frames[n] = {"c": c, "z": z, "x": x}
    # The third molars: the second molar's axes, centred on their own crown.
    for third, second in ((32, 31), (17, 18)):
        z, x = frames[second]["z"], frames[second]["x"]
        v = meshes[third][0]
        h = v @ z
        crown = v[h > h.max() - CROWN_HEIGHT[8]]
        c = crown.mean(axis=0)
        frames[third] = {"c": c, "z": z, "x": x}
    for n, f in frames.items():
        v = meshes[n][0]
        h = (v - f["c"]) @ f["z"]
        f["top"] = h.max()
        f["tip"] = v[np.argmax(h)]
        f["cej"] = f["c"] + (h.max() - CROWN_HEIGHT[FDI[n] % 10]) * f["z"]
    # The "mesial" axis of the data set points away from the midline here: check it on 46 and 36.
    for n, toward_front in ((30, 29), (19, 20)):
        d = frames[toward_front]["c"] - frames[n]["c"]
        if frames[n]["x"].dot(d) > 0:
            sys.exit("make_real_arch: the data set's x axis of tooth %d points mesially; update the script" % n)
    return frames


def world_frame(frames):
    """Rotation R (rows: world x, y, z in scan coordinates) and origin O (scan, mm)."""
    tips = np.array([frames[n]["tip"] for n in ARCH])
    centred = tips - tips.mean(axis=0)
    z = unit(np.linalg.svd(centred)[2][2])
    if z.dot(np.mean([f["z"] for f in frames.values()], axis=0)) < 0:
        z = -z
    origin = 0.5 * (frames[30]["cej"] + frames[19]["cej"])
    x = frames[19]["cej"] - frames[30]["cej"]
    x = unit(x - x.dot(z) * z)
    y = np.cross(z, x)
    return np.array([x, y, z]), origin


def axis_angle(r):
    """Axis (unit) and angle (degrees) of a rotation matrix."""
    angle = math.acos(max(-1.0, min(1.0, (np.trace(r) - 1.0) / 2.0)))
    if angle < 1e-9:
        return np.array([0.0, 0.0, 1.0]), 0.0
    axis = np.array([r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]])
    return unit(axis), math.degrees(angle)


def closest_pair(a, b):
    """Closest pair of vertices (mm) between two vertex sets, by chunks."""
    lo, hi = b.min(axis=0) - 3.0, b.max(axis=0) + 3.0
    a = a[np.all((a > lo) & (a < hi), axis=1)]
    best = (np.inf, None, None)
    for k in range(0, len(a), 2048):
        d = np.linalg.norm(a[k:k + 2048, None, :] - b[None, :, :], axis=2)
        i, j = np.unravel_index(np.argmin(d), d.shape)
        if d[i, j] < best[0]:
            best = (d[i, j], a[k + i], b[j])
    return best


def ray_hit(verts, faces, origin, direction):
    """Nearest crossing (mm along direction, either sign) of a line with a mesh, and the face's normal."""
    p0, p1, p2 = verts[faces[:, 0]], verts[faces[:, 1]], verts[faces[:, 2]]
    e1, e2 = p1 - p0, p2 - p0
    pv = np.cross(direction, e2)
    det = np.einsum("ij,ij->i", e1, pv)
    ok = np.abs(det) > 1e-12
    inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), 0.0)
    tv = origin - p0
    u = np.einsum("ij,ij->i", tv, pv) * inv
    qv = np.cross(tv, e1)
    v = (qv @ direction) * inv
    t = np.einsum("ij,ij->i", e2, qv) * inv
    hit = ok & (u >= 0) & (v >= 0) & (u + v <= 1)
    if not hit.any():
        return None, None
    idx = np.where(hit)[0]
    k = idx[np.argmin(np.abs(t[idx]))]
    return t[k], unit(np.cross(e1[k], e2[k]))


def surface_normal(verts, faces, point, radius):
    """Area-weighted outward normal of the faces within `radius` of `point`."""
    centres = verts[faces].mean(axis=1)
    near = np.linalg.norm(centres - point, axis=1) < radius
    n = np.cross(verts[faces[near, 1]] - verts[faces[near, 0]], verts[faces[near, 2]] - verts[faces[near, 0]])
    return unit(n.sum(axis=0))


def fmt(v, digits=3):
    """A YAML sequence of numbers with at most `digits` decimals."""
    out = []
    for x in v:
        text = "%.*f" % (digits, x)
        if "." in text:
            text = text.rstrip("0").rstrip(".")
        out.append("0" if text in ("-0", "") else text)
    return "[" + ", ".join(out) + "]"


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "scenes", "real-arch.yaml")
    axes = json.load(open(os.path.join(DATA, "teeth_axes_mandible.json")))
    meshes = {n: load_ply(os.path.join(DATA, "tooth_%d.ply" % n)) for n in ARCH}
    frames = tooth_frames(meshes, axes)
    rot, origin = world_frame(frames)
    world = lambda p: rot @ (p - origin)  # scan point -> world
    axis, angle = axis_angle(rot)
    position = -rot @ origin

    # The lesions, in the scan (object) frame.
    f46, f36 = frames[30], frames[19]
    v46, t46 = meshes[30]
    occlusal46 = f46["c"] + (f46["top"] + 1.0) * f46["z"]
    occlusal36 = f36["c"] + (f36["top"] + 1.0) * f36["z"]
    gap, on46, on45 = closest_pair(v46, meshes[29][0])
    target = on46 - CONTACT_TO_LESION * f46["z"]
    mesial = -f46["x"]
    # Onto 46's mesial surface along its mesial direction, then the scan's outward normal there.
    t, _ = ray_hit(v46, t46, target, mesial)
    if t is None:
        sys.exit("make_real_arch: no mesial surface of 46 below the contact with 45")
    site = target + t * mesial
    normal = surface_normal(v46, t46, site, 0.8)
    buccal = np.cross(f46["z"], f46["x"])  # unit, bucco-lingual direction on 46
    tangent = unit(buccal - buccal.dot(normal) * normal)
    gap45 = np.min(np.linalg.norm(meshes[29][0] - site, axis=1))

    # The gingiva path: the CEJs in world coordinates, raised; and the tongue.
    path = [world(frames[n]["cej"]) + np.array([0.0, 0.0, GUM_ABOVE_CEJ]) for n in ARCH]
    molar_cej_z = 0.5 * (world(f46["cej"])[2] + world(f36["cej"])[2])
    tongue_z = molar_cej_z + TONGUE_TOP_ABOVE_CEJ - 0.5 * TONGUE["height"]
    # Clear of the teeth: the tongue's centre between the first molars, pushed back until its
    # superellipsoid (geometry/procedural.cpp: |x/a|^3 + |y/b|^3, then ^2.5 with |z/c|) clears every
    # tooth vertex by 1.5 mm (scaled).
    all_world = np.vstack([(rot @ (meshes[n][0] - origin).T).T for n in ARCH])

    def tongue_clear(cy):
        a, b, c = 0.5 * TONGUE["length"], 0.5 * TONGUE["width"], 0.5 * TONGUE["height"]
        # Tongue frame: long axis along world -y (the tip, at the tongue's +x, toward the incisors).
        q = all_world - np.array([0.0, cy, tongue_z])
        tx, ty, tz = -q[:, 1], q[:, 0], q[:, 2]
        narrow = 1.0 - 0.35 * np.clip((tx / a + 0.2) / 1.2, 0, 1) ** 2 * (3 - 2 * np.clip((tx / a + 0.2) / 1.2, 0, 1))
        plan = (np.abs(tx / (a + 1.5)) ** 3 + np.abs(ty / (b * narrow + 1.5)) ** 3) ** (1 / 3)
        norm = (plan ** 2.5 + np.abs(tz / (c + 1.5)) ** 2.5) ** (1 / 2.5)
        return norm.min() > 1.0

    cy = -20.0
    while not tongue_clear(cy):
        cy += 0.5
        if cy > 30:
            sys.exit("make_real_arch: no place for the tongue")

    # Tool home: 10 mm above 46's highest point, tip lowest, handle toward the front.
    home = world(f46["c"] + f46["top"] * f46["z"]) + np.array([0.0, 0.0, 10.0])

    # Report.
    print("world: origin (scan) %s, rotation axis %s angle %.3f deg" % (fmt(origin), fmt(axis, 4), angle))
    for n in ARCH:
        f = frames[n]
        print("FDI %d: CEJ (world) %s, top %s" % (FDI[n], fmt(world(f["cej"])), fmt(world(f["c"] + f["top"] * f["z"]))))
    print("45-46 contact: closest vertices %.3f mm apart at %s (world)" % (gap, fmt(world(on46))))
    print("lesion2: site %s (world), normal %s, %.2f mm from 45" % (fmt(world(site)), fmt(rot @ normal), gap45))
    print("tongue centre y %.1f z %.1f" % (cy, tongue_z))

    lines = []
    w = lines.append
    w("# Generated by scripts/scenes/make_real_arch.py; edit the script, not this file.")
    w("#")
    w("# A real mouth: patient 26's sixteen scanned lower teeth (Open-Full-Jaw, data/open-full-jaw: its")
    w("# README gives the citation and the licence) in their scanned positions, a gingiva band along their")
    w("# cervical lines, the tongue inside the arch and the paper's three lesions (section 5.3): #1 in the")
    w("# central fossa of 46, #2 on the mesial surface of 46 below its contact with 45 (an explorer reaches")
    w("# it only through the embrasure, tip toward 46), #3 along the central fissure of 36.")
    w("#")
    w("# World frame (docs/scene-format.md), as oral-cavity: origin midway between the cemento-enamel")
    w("# junctions (CEJ) of 46 and 36, x toward the patient's left, y toward the back, z up (normal to the")
    w("# plane through the cusp tips). Every tooth has the same pose, scan -> world, so the scan's")
    w("# relative positions are kept. Mesh files named data:PATH are in the data folder the program ships.")
    w("# Lesion placements are in the tooth's frame, i.e. the scan's coordinates (mm).")
    w("name: real-arch")
    w("description: Patient 26's sixteen scanned lower teeth, gingiva along their cervical lines, tongue; three hidden lesions.")
    w("format: 1")
    w("")
    w("objects:")
    pose = "{position: %s, rotation: {axis: %s, angle: %.4f}}" % (fmt(position, 4), fmt(axis, 6), angle)
    for n in ARCH:
        fdi = FDI[n]
        w("  - name: tooth%d" % fdi)
        w("    fdi: %d" % fdi)
        w("    shape: {type: mesh, file: %s/tooth_%d.ply}" % (DATA_REF, n))
        w("    pose: %s" % pose)
        w("    tissue: enamel")
        if fdi in (36, 46):
            w("    enamel_thickness: 1.5")
        if fdi in FINE:
            w("    tree: {mode: tight, tolerance: 0.015, max_radius: 1.0}")
        else:
            w("    tree: {mode: tight, tolerance: 0.05, max_radius: 1.5}")
        w("")
    w("  # The gums: a band along the CEJs (%.0f mm above them; its rounded top meets a molar's buccal" % GUM_ABOVE_CEJ)
    w("  # and lingual faces about at the CEJ), %.0f mm wide and %.0f mm deep: it covers every root." % (GUM_WIDTH, GUM_HEIGHT))
    w("  - name: gingiva")
    w("    shape:")
    w("      type: gingiva")
    w("      path:")
    for n, p in zip(ARCH, path):
        w("        - %s  # %d" % (fmt(p), FDI[n]))
    w("      width: %.1f" % GUM_WIDTH)
    w("      height: %.1f" % GUM_HEIGHT)
    w("    tissue: gingiva")
    w("    material: {stiffness: 0.3}")
    w("    tree: {mode: tight, tolerance: 0.08, max_radius: 2.0}")
    w("")
    w("  # The tongue inside the arch, its tip toward the incisors, its top %.0f mm above the molars' CEJs," % TONGUE_TOP_ABOVE_CEJ)
    w("  # at least 1.5 mm from every tooth.")
    w("  - name: tongue")
    w("    shape: {type: tongue, length: %.1f, width: %.1f, height: %.1f}" % (TONGUE["length"], TONGUE["width"], TONGUE["height"]))
    w("    pose: {position: %s, rotation: {axis: [0, 0, 1], angle: -90}}" % fmt([0.0, cy, tongue_z]))
    w("    tissue: tongue")
    w("    material: {stiffness: 0.15}")
    w("    tree: {mode: tight, tolerance: 0.05, max_radius: 2.0}")
    w("")
    w("lesions:")
    w("  # #1: occlusal, in the central fossa of 46 (placed on its long axis above the crown and snapped")
    w("  # down); severe, softer below the enamel; a cavity with a flat floor 2.5 mm down.")
    w("  - name: lesion1")
    w("    object: tooth46")
    w("    placement: {at: %s, normal: %s, snap_range: 4.0}" % (fmt(occlusal46), fmt(f46["z"], 4)))
    w("    shape: {type: disk, size: 2.2, depth: 2.5}")
    w("    severity: severe")
    w("    material:")
    w("      k_c:")
    w("        layers:")
    w("          - {to: 1.5, k_c: 0.3}")
    w("          - {to: 2.5, k_c: 0.2}")
    w("")
    w("  # #2: interproximal, on the mesial surface of 46 %.1f mm cervical to its contact with 45 (%.2f mm" % (CONTACT_TO_LESION, gap45))
    w("  # from 45 there): hidden under the contact, reached only by an explorer whose tip comes through")
    w("  # the buccal or lingual embrasure toward 46. Wider bucco-lingually than tall, 1.3 mm deep.")
    w("  - name: lesion2")
    w("    object: tooth46")
    w("    placement: {at: %s, normal: %s, tangent: %s, snap_range: 1.5}" % (fmt(site), fmt(normal, 4), fmt(tangent, 4)))
    w("    shape: {type: ellipsoid, size: 2.0, width: 1.4, depth: 1.3}")
    w("    severity: severe")
    w("")
    w("  # #3: occlusal, a stripe along the central fissure of 36 (mesio-distal); mild (enamel only).")
    w("  - name: lesion3")
    w("    object: tooth36")
    w("    placement: {at: %s, normal: %s, tangent: %s, snap_range: 4.0}" % (fmt(occlusal36), fmt(f36["z"], 4), fmt(f36["x"], 4)))
    w("    shape: {type: stripe, size: 3.0, width: 0.8, depth: 1.2}")
    w("    severity: mild")
    w("")
    w("tool:")
    w("  tip_radius: 0.05")
    w("  # Starts 10 mm above 46's highest cusp, the tip lowest, the handle rising toward the front of the")
    w("  # mouth (as in oral-cavity).")
    w("  home: {position: %s, rotation: {axis: [-0.3893, -0.3893, -0.8348], angle: 100.289}}" % fmt(home))
    w("")
    w("device: {max_force: 22.0, max_stiffness: 1.0, max_torque: 500.0, position_resolution: 0.02}")
    w("coupling: {k_trans: 1.0, k_rot: 150.0}")
    w("servo_rate: 1000")
    with open(out, "w") as f:
        f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
