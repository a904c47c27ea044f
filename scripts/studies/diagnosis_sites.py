#!/usr/bin/python3
"""Prints the lesion sites of the built-in diagnosis study (studies/diagnosis.yaml) on the real-arch
scene's scanned teeth, in each tooth's frame (the scan's coordinates), with the methods
scripts/scenes/make_real_arch.py uses for the scene's own lesions:
  - occlusal: on the tooth's long axis, 1 mm above its highest point, pointing along the axis (the
    scene snaps it down onto the fossa or groove);
  - interproximal: on the tooth's mesial surface 1.5 mm cervical to its contact with the mesial
    neighbour (the closest pair of scan vertices), with the scan's outward normal there and the
    bucco-lingual direction as the shape's tangent.

Usage: scripts/studies/diagnosis_sites.py   (needs numpy: Debian's python3-numpy)
"""
import os
import sys

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "scenes"))
import make_real_arch as ra  # noqa: E402

# (Universal number of the tooth, of its mesial neighbour) for the interproximal sites.
OCCLUSAL = [30, 31, 29, 19, 18, 20]
INTERPROXIMAL = [(30, 29), (19, 20)]


def main():
    axes = ra.json.load(open(os.path.join(ra.DATA, "teeth_axes_mandible.json")))
    meshes = {n: ra.load_ply(os.path.join(ra.DATA, "tooth_%d.ply" % n)) for n in ra.ARCH}
    frames = ra.tooth_frames(meshes, axes)
    for n in OCCLUSAL:
        f = frames[n]
        at = f["c"] + (f["top"] + 1.0) * f["z"]
        print("    - {name: %d-occlusal, object: tooth%d, site: occlusal, at: %s, normal: %s, snap_range: 4.0}"
              % (ra.FDI[n], ra.FDI[n], ra.fmt(at), ra.fmt(f["z"], 4)))
    for n, front in INTERPROXIMAL:
        f = frames[n]
        verts, faces = meshes[n]
        _, on_tooth, _ = ra.closest_pair(verts, meshes[front][0])
        target = on_tooth - ra.CONTACT_TO_LESION * f["z"]
        mesial = -f["x"]
        t, _ = ra.ray_hit(verts, faces, target, mesial)
        if t is None:
            sys.exit("diagnosis_sites: no mesial surface of %d below its contact" % ra.FDI[n])
        site = target + t * mesial
        normal = ra.surface_normal(verts, faces, site, 0.8)
        buccal = np.cross(f["z"], f["x"])
        tangent = ra.unit(buccal - buccal.dot(normal) * normal)
        print("    - {name: %d-mesial, object: tooth%d, site: interproximal, at: %s, normal: %s, tangent: %s, "
              "snap_range: 1.5}" % (ra.FDI[n], ra.FDI[n], ra.fmt(site), ra.fmt(normal, 4), ra.fmt(tangent, 4)))


if __name__ == "__main__":
    main()
