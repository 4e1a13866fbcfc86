#!/usr/bin/env python3
"""Writes point sets for `Points` nodes and the benchmarks at scale: a binary
PLY, a plain XYZ text file (what the splashsurf peer reads), and a scene that
renders the PLY.

Two models, both with supports of radius 2.25 (the particles scene's):

  sparse  the particles scene's density at any N: chains of 50 random-walk
          points, step 1.8, each started uniformly in a cube of side
          28 * (N / 1000)^(1/3), so a point overlaps about as many others at
          every N.
  dense   one branching random walk, step 1.8: each new point steps from the
          one before it, or with probability 0.3 from a uniformly chosen
          earlier one; at a million points a support overlaps about 90 others,
          as fluid particles do.

Run from the repository root, e.g.
  python3 scenes/tools/make_points.py sparse 100000 out/points
writes out/points/sparse-100000.ply, .xyz and .ron. Nothing this writes is
committed: the tests make small sets themselves.
"""
import math
import os
import random
import struct
import sys

STEP, RADIUS, CHAIN = 1.8, 2.25, 50


def unit_step(rng):
    """A step of length STEP in a uniformly random direction."""
    theta = rng.uniform(0.0, 2.0 * math.pi)
    z = rng.uniform(-1.0, 1.0)
    r = math.sqrt(1.0 - z * z)
    return (STEP * r * math.cos(theta), STEP * r * math.sin(theta), STEP * z)


def sparse(n, rng):
    half = 14.0 * (n / 1000.0) ** (1.0 / 3.0)
    points = []
    while len(points) < n:
        p = (rng.uniform(-half, half), rng.uniform(-half, half), rng.uniform(-half, half))
        for _ in range(CHAIN):
            if len(points) >= n:
                break
            points.append(p)
            s = unit_step(rng)
            p = (p[0] + s[0], p[1] + s[1], p[2] + s[2])
    return points


def dense(n, rng):
    points = [(0.0, 0.0, 0.0)]
    while len(points) < n:
        base = points[-1] if rng.random() >= 0.3 else points[rng.randrange(len(points))]
        s = unit_step(rng)
        points.append((base[0] + s[0], base[1] + s[1], base[2] + s[2]))
    return points


def write_ply(path, points):
    header = (
        "ply\nformat binary_little_endian 1.0\n"
        f"comment {len(points)} points, support radius {RADIUS} (scenes/tools/make_points.py)\n"
        f"element vertex {len(points)}\nproperty float x\nproperty float y\nproperty float z\nend_header\n"
    )
    with open(path, "wb") as f:
        f.write(header.encode())
        f.write(b"".join(struct.pack("<3f", *p) for p in points))


def write_xyz(path, points):
    with open(path, "w") as f:
        f.write("".join(f"{p[0]:.6f} {p[1]:.6f} {p[2]:.6f}\n" for p in points))


def write_scene(path, ply_name, points):
    lo = [min(p[k] for p in points) for k in range(3)]
    hi = [max(p[k] for p in points) for k in range(3)]
    centre = [(a + b) / 2 for a, b in zip(lo, hi)]
    reach = max(b - a for a, b in zip(lo, hi)) / 2 + RADIUS
    with open(path, "w") as f:
        f.write(
            "// Written by scenes/tools/make_points.py.\n"
            "Scene(\n"
            f"    camera: Camera(eye: ({centre[0]:.3f}, {centre[1] - 3.2 * reach:.3f}, {centre[2]:.3f}), "
            f"target: ({centre[0]:.3f}, {centre[1]:.3f}, {centre[2]:.3f}), up: (0.0, 0.0, 1.0), fov_y: 60.0),\n"
            "    size: (500, 500),\n"
            "    threshold: 0.5,\n"
            f'    model: Named("cloud", Points(file: "{ply_name}", radius: {RADIUS})),\n'
            ")\n"
        )


def main():
    if len(sys.argv) != 4 or sys.argv[1] not in ("sparse", "dense"):
        sys.exit("usage: make_points.py sparse|dense N OUT_DIR")
    model, n, out = sys.argv[1], int(sys.argv[2]), sys.argv[3]
    if n < 1:
        sys.exit("N must be at least 1")
    os.makedirs(out, exist_ok=True)
    points = (sparse if model == "sparse" else dense)(n, random.Random(7))
    stem = os.path.join(out, f"{model}-{n}")
    write_ply(stem + ".ply", points)
    write_xyz(stem + ".xyz", points)
    write_scene(stem + ".ron", os.path.basename(stem) + ".ply", points)
    print(f"wrote {stem}.ply, .xyz and .ron ({n} points)")


if __name__ == "__main__":
    main()
