#!/usr/bin/python3
"""Writes the built-in diagnosis studies studies/diagnosis.yaml and studies/diagnosis-paper.yaml: their
lesion sites, one region per site on every posterior tooth of the real-arch scene (34-37, 44-47), in
each tooth's frame (the scan's coordinates), with the methods scripts/scenes/make_real_arch.py uses
for the scene's own lesions. Each tooth has (u mesio-distal, toward distal; v bucco-lingual; z its
long axis, occlusal; `top` its highest point along z):

  - occlusal-fossa: molars, the central fossa on the long axis (the paper's #1 on 46); premolars, the
    distal fossa 1.6 mm distal of the axis at the lowest point across the crown. Placed 1 mm above the
    crown and snapped down along z. Disk or inverted cone.
  - occlusal-fissure: the central groove, molars 2 mm mesial of the axis, premolars on the axis, at
    the lowest point across the crown; a stripe along the mesio-distal direction.
  - buccal-pit, lingual-pit (molars): the buccal (lingual) surface 3 mm below that side's highest
    cusp, on the long axis's mesio-distal middle, with the scan's outward normal there. Disk or
    inverted cone.
  - mesial, distal: the surface facing the mesial (distal) neighbour 1.5 mm cervical to the contact
    (the closest pair of scan vertices), with the scan's outward normal there and the bucco-lingual
    direction as the shape's tangent (the paper's #2 on 46's mesial surface). Ellipsoid. Where the
    neighbour touches more than 4 mm below the highest cusp (e.g. the tilted third molars behind 37 and
    47), the surface 4.5 mm below that cusp on the axis's mesio-distal line instead.

Each region is an ellipse in the site's tangent plane (half-axes along the tangent and across it);
the script checks that every point of its rim snaps onto the tooth within the site's snap range along
its normal, as the scene builder snaps a lesion (src/scene/model_builder.cpp), and shrinks the region
until it does. `diagnosis` draws every case from the trial's seed; `diagnosis-paper` has the paper's
three lesions as its first case (docs/training.md).

Usage: scripts/studies/diagnosis_sites.py [--check]   (needs numpy: Debian's python3-numpy)
  --check: write nothing; exit 1 when the study files differ from what the script makes.
"""
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "scenes"))
import make_real_arch as ra  # noqa: E402

STUDIES = os.path.join(ra.ROOT, "studies")
MOLARS = [31, 30, 18, 19]  # Universal numbers of 47, 46, 37, 36
PREMOLARS = [29, 28, 20, 21]  # 45, 44, 35, 34
# Region half-axes (mm, along the tangent and across it) and snap ranges (mm) per site kind.
REGION = {"occlusal-fossa": (0.7, 0.7), "occlusal-fissure": (0.6, 0.25), "pit": (0.6, 0.4),
          "interproximal": (0.6, 0.3)}
PREMOLAR_FOSSA = (0.4, 0.4)
SNAP = {"occlusal": 4.0, "pit": 1.5, "interproximal": 1.5}
SHAPES = {"occlusal-fossa": "[disk, inverted-cone]", "occlusal-fissure": "[stripe]",
          "buccal-pit": "[disk, inverted-cone]", "lingual-pit": "[disk, inverted-cone]",
          "mesial": "[ellipsoid]", "distal": "[ellipsoid]"}
PIT_BELOW_TOP = 3.0  # mm, a pit below the highest cusp of its side
CROWN_CONTACT = 4.0  # mm, deepest a contact with the neighbour lies below the highest cusp
USUAL_CONTACT = 3.0  # mm, where it is taken to be when the neighbour touches deeper
MOLAR_FISSURE_MESIAL = 2.0  # mm, a molar's fissure site mesial of its axis
PREMOLAR_FOSSA_DISTAL = 1.6  # mm, a premolar's distal fossa distal of its axis


def neighbours(n):
    """(mesial, distal) neighbours' Universal numbers: 25-32 is the right side (mesial = n - 1)."""
    return (n - 1, n + 1) if n >= 25 else (n + 1, n - 1)


def lowest_across(mesh, f, u, half_width=1.5, step=0.125):
    """The point of the crown's occlusal surface at mesio-distal u (mm from the axis) lowest along z
    across the crown (|v| <= half_width), seen from above along -z."""
    verts, faces = mesh
    b = np.cross(f["z"], f["x"])
    best = None
    for v in np.arange(-half_width, half_width + 1e-9, step):
        origin = f["c"] + u * f["x"] + v * b + (f["top"] + 1.0) * f["z"]
        t, _ = ra.ray_hit(verts, faces, origin, -f["z"])
        if t is None:
            continue
        if best is None or t > best[0]:
            best = (t, v)
    if best is None:
        sys.exit("diagnosis_sites: no occlusal surface at u = %.1f on %d" % (u, ra.FDI[f["n"]]))
    return f["c"] + u * f["x"] + best[1] * b + (f["top"] + 1.0) * f["z"]


def rim(at, normal, tangent, region):
    """The region's centre and eight points of its rim (the ellipse's half-axes along the tangent and
    across it)."""
    across = np.cross(normal, tangent)
    points = [at]
    for k in range(8):
        a = k * math.pi / 4.0
        points.append(at + region[0] * math.cos(a) * tangent + region[1] * math.sin(a) * across)
    return points


def snaps(mesh, at, normal, tangent, region, snap_range):
    """True when every rim point meets the tooth along the normal within the snap range (less a margin
    of 0.25 mm), on a face that looks the normal's way."""
    verts, faces = mesh
    for p in rim(at, normal, tangent, region):
        t, face_normal = ra.ray_hit(verts, faces, p, normal)
        if t is None or abs(t) > snap_range - 0.25:
            return False
        if face_normal is not None and abs(face_normal.dot(normal)) < 0.2:
            return False
    return True


def fitted(mesh, name, at, normal, tangent, region, snap_range):
    """The region shrunk (by 10 % a step) until every rim point snaps; exits when even a point does not."""
    while not snaps(mesh, at, normal, tangent, region, snap_range):
        region = (0.9 * region[0], 0.9 * region[1])
        if region[0] < 0.1:
            sys.exit("diagnosis_sites: site %s does not snap onto its tooth" % name)
    return (math.floor(region[0] * 100) / 100, math.floor(region[1] * 100) / 100)


def in_plane(direction, normal):
    return ra.unit(direction - direction.dot(normal) * normal)


def site_line(name, fdi, kind, at, normal, tangent, region, snap_range):
    return ("    - {name: %s, object: tooth%d, site: %s, at: %s, normal: %s, tangent: %s, region: %s, "
            "snap_range: %s, shapes: %s}" % (name, fdi, kind, ra.fmt(at), ra.fmt(normal, 4), ra.fmt(tangent, 4),
                                              ra.fmt(region, 2), ra.fmt([snap_range], 1)[1:-1], SHAPES[kind]))


def sites():
    """The study's site lines, tooth by tooth (47 to 44, then 34 to 37)."""
    axes = ra.json.load(open(os.path.join(ra.DATA, "teeth_axes_mandible.json")))
    meshes = {n: ra.load_ply(os.path.join(ra.DATA, "tooth_%d.ply" % n)) for n in ra.ARCH}
    frames = ra.tooth_frames(meshes, axes)
    for n, f in frames.items():
        f["n"] = n
    midline = 0.5 * (frames[30]["c"] + frames[19]["c"])
    lines = []
    for n in [31, 30, 29, 28, 21, 20, 19, 18]:
        f, mesh, fdi = frames[n], meshes[n], ra.FDI[n]
        verts, faces = mesh
        z, x = f["z"], f["x"]
        b = np.cross(z, x)
        lingual = b if b.dot(midline - f["c"]) > 0 else -b
        molar = n in MOLARS
        lines.append("    # %d (%s)" % (fdi, "molar" if molar else "premolar"))
        occlusal = []
        if molar:
            occlusal.append(("occlusal-fossa", f["c"] + (f["top"] + 1.0) * z, REGION["occlusal-fossa"]))
            occlusal.append(("occlusal-fissure", lowest_across(mesh, f, -MOLAR_FISSURE_MESIAL),
                             REGION["occlusal-fissure"]))
        else:
            occlusal.append(("occlusal-fissure", lowest_across(mesh, f, 0.0), REGION["occlusal-fissure"]))
            occlusal.append(("occlusal-fossa", lowest_across(mesh, f, PREMOLAR_FOSSA_DISTAL), PREMOLAR_FOSSA))
        for kind, at, region in occlusal:
            name = "%d-%s" % (fdi, kind)
            region = fitted(mesh, name, at, z, x, region, SNAP["occlusal"])
            lines.append(site_line(name, fdi, kind, at, z, x, region, SNAP["occlusal"]))
        if molar:
            for kind, side in (("buccal-pit", -lingual), ("lingual-pit", lingual)):
                rel = verts - f["c"]
                side_top = (rel @ z)[rel @ side > 1.0].max()
                origin = f["c"] + (side_top - PIT_BELOW_TOP) * z + 10.0 * side
                t, _ = ra.ray_hit(verts, faces, origin, -side)
                if t is None:
                    sys.exit("diagnosis_sites: no %s surface on %d" % (kind, fdi))
                at = origin - t * side
                normal = ra.surface_normal(verts, faces, at, 0.8)
                tangent = in_plane(x, normal)
                name = "%d-%s" % (fdi, kind)
                region = fitted(mesh, name, at, normal, tangent, REGION["pit"], SNAP["pit"])
                lines.append(site_line(name, fdi, kind, at, normal, tangent, region, SNAP["pit"]))
        for kind, other, toward in zip(("mesial", "distal"), neighbours(n), (-x, x)):
            _, on_tooth, _ = ra.closest_pair(verts, meshes[other][0])
            target = on_tooth - ra.CONTACT_TO_LESION * z
            if f["top"] - (on_tooth - f["c"]).dot(z) > CROWN_CONTACT:
                # The neighbour touches below the crown (a tilted third molar): where a crown contact
                # would be, on the axis's mesio-distal line, seen from outside the tooth.
                target = f["c"] + (f["top"] - USUAL_CONTACT - ra.CONTACT_TO_LESION) * z + 10.0 * toward
            t, _ = ra.ray_hit(verts, faces, target, toward)
            if t is None:
                sys.exit("diagnosis_sites: no %s surface of %d below its contact" % (kind, fdi))
            at = target + t * toward
            normal = ra.surface_normal(verts, faces, at, 0.8)
            tangent = in_plane(b, normal)
            name = "%d-%s" % (fdi, kind)
            region = fitted(mesh, name, at, normal, tangent, REGION["interproximal"], SNAP["interproximal"])
            lines.append(site_line(name, fdi, kind, at, normal, tangent, region, SNAP["interproximal"]))
    return lines


HEADER = """\
# Generated by scripts/studies/diagnosis_sites.py; edit the script, not this file.
#
# Paper section 5.3, Figs. 15-17: caries diagnosis in the oral cavity. The real-arch scene (sixteen
# scanned lower teeth, gingiva, tongue) with its own lesions removed and the case's lesions hidden
# instead. The participant explores, marks each suspected lesion by holding the tip on it and pressing
# the mark key (or a device button), grades it mild or severe, and ends the case; 180 s per case.
#
# Sites: regions on every posterior tooth (34-37, 44-47): the occlusal fossae and fissures, the molars'
# buccal and lingual pits, the mesial and distal surfaces below the contacts. Each is an ellipse in the
# tooth's tangent plane there (`region`: half-axes in mm along the tangent and across it), in the
# tooth's frame (the scan's coordinates); a lesion's place within it, its shape (of `shapes`), size,
# depth and severity are drawn from the trial's seed and its centre snapped onto the tooth
# (docs/training.md).
"""

DIAGNOSIS = """\
# Every case is drawn: one to three lesions per case, and the trial's seed depends on the participant,
# so no two trainees share a case unless their course sets an `exam_seed` (docs/instructors.md).
name: diagnosis
description: Find, count and grade hidden caries in the oral cavity (paper section 5.3); every case drawn.
"""

PAPER = """\
# The first case is the paper's three lesions: #1 severe in the central fossa of 46, #2 severe on the
# mesial surface of 46 below its contact with 45 (reached only through the embrasure), #3 mild, a
# stripe along the central fissure of 36 (the 36-occlusal-fossa site's centre, with its mesio-distal
# tangent); they are the real-arch scene's own lesions. Later cases are drawn as in `diagnosis`.
name: diagnosis-paper
description: The paper's diagnosis case (section 5.3) first, then drawn cases.
"""

BODY_HEAD = """\
format: 1
kind: diagnosis
trials: 3
"""

# The built-in diagnosis study teaches: a debrief after each case. The paper's case does not set it.
DEBRIEF = "debrief: after-each-case     # the trainee sees each case's lesions, marks and replay (docs/training.md)\n"

BODY = """\
diagnosis:
  scene: real-arch
  time_limit: 180.0
  detection_margin: 0.5
  sites:
"""

CASES = """\
  cases:
    - lesions:
        - {site: 46-occlusal-fossa, shape: disk, severity: severe, size: 2.2, depth: 2.5}
        - {site: 46-mesial, shape: ellipsoid, severity: severe, size: 2.0, width: 1.4, depth: 1.3}
        - {site: 36-occlusal-fossa, shape: stripe, severity: mild, size: 3.0, width: 0.8, depth: 1.2}
"""

GENERATE = """\
  generate:
    count: [1, 3]
    mild_fraction: 0.5
    size: [1.6, 2.6]
    width: [0.8, 1.4]
    mild_depth: [0.6, 1.2]
    severe_depth: [1.3, 2.5]
"""


def main():
    check = sys.argv[1:] == ["--check"]
    if sys.argv[1:] and not check:
        sys.exit(__doc__)
    site_text = "\n".join(sites()) + "\n"
    files = {
        "diagnosis.yaml": HEADER + DIAGNOSIS + BODY_HEAD + DEBRIEF + BODY + site_text + GENERATE,
        "diagnosis-paper.yaml": HEADER + PAPER + BODY_HEAD + BODY + site_text + CASES + GENERATE,
    }
    stale = []
    for name, text in files.items():
        path = os.path.join(STUDIES, name)
        if check:
            old = open(path).read() if os.path.exists(path) else ""
            if old != text:
                stale.append(path)
        else:
            with open(path, "w") as out:
                out.write(text)
            print("wrote %s" % path)
    if stale:
        sys.exit("diagnosis_sites: out of date (run scripts/studies/diagnosis_sites.py): %s" % ", ".join(stale))


if __name__ == "__main__":
    main()
