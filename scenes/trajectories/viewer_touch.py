#!/usr/bin/env python3
"""Writes scenes/trajectories/viewer-touch-<scene>.csv, the scripted-device trajectories of the
viewer's Xvfb test and benchmark (docs/viewer.md): from the scene's tool home (same orientation)
the tip moves above a tooth or block, comes down onto its surface, presses 0.5 mm below it at
t = 2.5 s and then slides +-0.3 mm back and forth (period 2 s) until t = 40 s.

The surface heights were found with `cariesim sim` on a slow vertical descent (the haptic z at
which the state leaves "free"). Run from anywhere: python3 scenes/trajectories/viewer_touch.py
"""
import math
import os

# scene: home position, home rotation (axis, degrees) as in the scene file, target (x, y), surface z
SCENES = {
    "oral-cavity": ((-22.5, 0.0, 20.0), ((-0.3893, -0.3893, -0.8348), 100.289), (-23.5, 12.0), 6.14),
    # real-arch: onto the flat top of a buccal cusp of the scanned 37 (7.41 mm; the tip's centre
    # 0.05 mm above it), where the tool is seen over the arch.
    "real-arch": ((-20.104, -0.347, 16.975), ((-0.3893, -0.3893, -0.8348), 100.289), (23.75, 9.75), 7.46),
    "friction-block": ((-25.0, 0.0, 10.0), ((0, 1, 0), -50.0), (-20.0, 0.0), 0.05),
    "boundary-square": ((-45.0, -45.0, 10.0), ((0, 1, 0), -50.0), (-40.0, -40.0), 0.05),
    "boundary-triangle": ((-45.0, -45.0, 10.0), ((0, 1, 0), -50.0), (-40.0, -40.0), 0.05),
    "boundary-circle": ((-45.0, -45.0, 10.0), ((0, 1, 0), -50.0), (-40.0, -40.0), 0.05),
    "insertion-blocks": ((-10.0, 0.0, 15.0), ((0.4226, 0, 0.9063), 180.0), (-12.0, 0.0), 0.05),
}
PRESS = 0.5       # mm below the surface
AMPLITUDE = 0.3   # mm, lateral sliding along x
PERIOD = 2.0      # s
END = 40.0        # s


def quaternion(axis, degrees):
    n = math.sqrt(sum(a * a for a in axis))
    h = math.radians(degrees) / 2.0
    return (math.cos(h),) + tuple(a / n * math.sin(h) for a in axis)


def rows(home, rotation, target, surface):
    q = quaternion(*rotation)
    x, y = target
    out = [(0.0, *home), (1.0, x, y, surface + 3.0), (2.0, x, y, surface + 0.3), (2.5, x, y, surface - PRESS)]
    t = 2.5
    while t < END:
        t += 0.1
        out.append((t, x + AMPLITUDE * math.sin(2.0 * math.pi * (t - 2.5) / PERIOD), y, surface - PRESS))
    return [r + q for r in out]


def main():
    folder = os.path.dirname(os.path.abspath(__file__))
    for scene, (home, rotation, target, surface) in SCENES.items():
        with open(os.path.join(folder, f"viewer-touch-{scene}.csv"), "w") as f:
            f.write("t,px,py,pz,qw,qx,qy,qz\n")
            for r in rows(home, rotation, target, surface):
                f.write(",".join(f"{v:.6g}" for v in r) + "\n")


if __name__ == "__main__":
    main()
