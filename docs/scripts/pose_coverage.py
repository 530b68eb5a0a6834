#!/usr/bin/env python3
"""How far a clip's poses are from every pose of the training clips.

    /usr/bin/python3 docs/scripts/pose_coverage.py CLIP.bvh JOINTS TRAIN.bvh ...

JOINTS: comma-separated joint names as CLIP names them. Joints are matched
across files by their index in the hierarchy (the CMU clips share one
joint order under two naming schemes); the training clips count mirrored
too (left and right swapped, reflected in x). Each joint's rotation
relative to its parent comes from the BVH's Euler channels; distances are
geodesic angles in degrees. Prints, per joint, the mean over the clip's
frames (every second) of the angle to the nearest training frame (every
third), then the mean of each frame's worst joint, and the mean and median
distance to the nearest whole training pose (a pose's distance being its
worst joint's).
"""
import sys

import numpy as np


def parse(path):
    head, motion = open(path).read().split("MOTION")
    names, channels = [], []
    for line in head.splitlines():
        t = line.split()
        if t and t[0] in ("ROOT", "JOINT"):
            names.append(t[1])
        if t and t[0] == "CHANNELS":
            channels.append(t[2:])
    lines = [l for l in motion.strip().splitlines()[2:] if l.strip()]
    return names, channels, np.array([[float(x) for x in l.split()] for l in lines])


def axis_rotation(axis, degrees):
    a = np.radians(degrees)
    c, s = np.cos(a), np.sin(a)
    i, j = {"X": (1, 2), "Y": (2, 0), "Z": (0, 1)}[axis]
    r = np.tile(np.eye(3), (len(a), 1, 1))
    r[:, i, i], r[:, i, j], r[:, j, i], r[:, j, j] = c, -s, s, c
    return r


def local_rotations(path):
    """Per joint index: #frames by 3 by 3 rotations relative to the parent."""
    names, channels, data = parse(path)
    out, column = [], 0
    for chans in channels:
        r = np.tile(np.eye(3), (len(data), 1, 1))
        for c in chans:
            if c.endswith("rotation"):
                r = r @ axis_rotation(c[0], data[:, column])
            column += 1
        out.append(r)
    return names, out


def mirrored(names, rotations):
    def swap(n):
        for a, b in (("Left", "Right"), ("LHip", "RHip"), ("LThumb", "RThumb")):
            if n.startswith(a):
                return b + n[len(a):]
            if n.startswith(b):
                return a + n[len(b):]
        return n
    m = np.diag([-1.0, 1.0, 1.0])
    index = {n: i for i, n in enumerate(names)}
    return [m @ rotations[index.get(swap(n), i)] @ m for i, n in enumerate(names)]


def angles(a, b):
    trace = np.einsum("nij,mij->nm", a, b)
    return np.degrees(np.arccos(np.clip((trace - 1.0) / 2.0, -1.0, 1.0)))


def main():
    if len(sys.argv) < 4:
        sys.exit(__doc__)
    try:
        names, clip = local_rotations(sys.argv[1])
        unknown = [j for j in sys.argv[2].split(",") if j not in names]
        if unknown:
            sys.exit(f"pose_coverage: {sys.argv[1]} has no joint {', '.join(unknown)}")
        joints = [names.index(j) for j in sys.argv[2].split(",")]
        train = []
        for path in sys.argv[3:]:
            _, rotations = local_rotations(path)
            if len(rotations) != len(names):
                sys.exit(f"pose_coverage: {path} has {len(rotations)} joints, {sys.argv[1]} {len(names)}")
            train += [rotations, mirrored(names, rotations)]
    except (OSError, ValueError) as e:
        sys.exit(f"pose_coverage: {e}")
    nearest, whole = [], None
    for j in joints:
        d = angles(clip[j][::2], np.concatenate([t[j][::3] for t in train]))
        nearest.append(d.min(axis=1))
        whole = d if whole is None else np.maximum(whole, d)
    nearest = np.array(nearest)
    for k, j in enumerate(joints):
        print(f"{names[j]:16s} {nearest[k].mean():5.1f}")
    print(f"worst joint of a frame {nearest.max(axis=0).mean():.1f}")
    print(f"nearest whole pose: mean {whole.min(axis=1).mean():.1f}, median {np.median(whole.min(axis=1)):.1f}")


if __name__ == "__main__":
    main()
