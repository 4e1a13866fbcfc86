#!/usr/bin/env python3
"""Writes scenes/medusa.ron and scenes/hair_point.ron.

The Medusa model of the caching paper (section 6.1): 9490 point primitives in
seven named components, each a blend of splines of points under a 128³ cache.
Each spline's weight is chosen so its field peaks at 1 along the curve, so a
tube's visible radius is about 0.42 × its support radius whatever the point count.

Run from the repository root:  python3 scenes/tools/make_medusa.py
"""
import math

COUNTS = {"tail": 810, "body": 840, "chest": 40, "left_hand": 570, "neck": 20, "head": 700, "hair": 6510}
COLORS = {
    "tail": (0.22, 0.42, 0.20), "body": (0.62, 0.70, 0.52), "chest": (0.62, 0.70, 0.52),
    "left_hand": (0.62, 0.70, 0.52), "neck": (0.62, 0.70, 0.52), "head": (0.66, 0.72, 0.56),
    "hair": (0.16, 0.36, 0.14),
}


def catmull_rom(p0, p1, p2, p3, t):
    t2, t3 = t * t, t * t * t
    return tuple(0.5 * (2 * b + (c - a) * t + (2 * a - 5 * b + 4 * c - d) * t2 + (3 * b - a - 3 * c + d) * t3)
                 for a, b, c, d in zip(p0, p1, p2, p3))


def even_points(control, count):
    """Mirror of field::spline::even_points (uniform Catmull-Rom, even arc length)."""
    at = lambda i: control[max(0, min(len(control) - 1, i))]
    line = []
    for s in range(len(control) - 1):
        for k in range(64):
            line.append(catmull_rom(at(s - 1), at(s), at(s + 1), at(s + 2), k / 64))
    line.append(control[-1])
    cum = [0.0]
    for a, b in zip(line, line[1:]):
        cum.append(cum[-1] + math.dist(a, b))
    total = cum[-1]
    out = []
    fractions = [0.5] if count == 1 else [i / (count - 1) for i in range(count)]
    for u in fractions:
        target = u * total
        k = next((i for i, c in enumerate(cum) if c >= target), len(cum) - 1)
        k = max(1, k)
        c0, c1 = cum[k - 1], cum[k]
        s = (target - c0) / (c1 - c0) if c1 > c0 else 0.0
        out.append(tuple(a + (b - a) * s for a, b in zip(line[k - 1], line[k])))
    return out


def unit_weight(control, count, r0, r1):
    """Weight making the spline's own field peak at 1 along the curve."""
    pts = even_points(control, count)
    radii = [r0 + (r1 - r0) * (i / max(1, count - 1)) for i in range(count)]
    step = max(1, count // 40)
    peak = 0.0
    for q in pts[::step]:
        f = 0.0
        for p, r in zip(pts, radii):
            d2 = sum((a - b) ** 2 for a, b in zip(p, q)) / (r * r)
            if d2 < 1:
                f += (1 - d2) ** 3
        peak = max(peak, f)
    return 1.0 / peak


class Component:
    def __init__(self, name):
        self.name, self.splines = name, []

    def spline(self, control, count, r0, r1=None):
        self.splines.append((control, count, r0, r0 if r1 is None else r1))

    def total(self):
        return sum(s[1] for s in self.splines)


def fmt(v):
    return "(" + ", ".join(f"{x:.4f}" for x in v) + ")"


def spline_ron(control, count, r0, r1, indent):
    w = unit_weight(control, count, r0, r1)
    ctrl = ", ".join(fmt(c) for c in control)
    end = f", radius_end: {r1:.4f}" if abs(r1 - r0) > 1e-9 else ""
    return f"{indent}SplinePoints(control: [{ctrl}], count: {count}, radius: {r0:.4f}{end}, weight: {w:.5f}),"


def component_ron(c, indent="        "):
    assert c.total() == COUNTS[c.name], (c.name, c.total())
    inner = "\n".join(spline_ron(*s, indent + "        ") for s in c.splines)
    col = fmt(COLORS[c.name])
    return (f'{indent}Named("{c.name}", Cache(res: 128, child: Transform(color: {col}, child: Blend([\n'
            f"{inner}\n{indent}])))),")


def tail():
    c = Component("tail")
    c.spline([(0.0, -0.1, 0.0), (0.05, -0.9, 0.15), (0.35, -1.6, 0.45), (1.1, -2.0, 0.35), (1.55, -2.05, -0.45),
              (0.9, -2.05, -1.25), (-0.3, -2.05, -1.35), (-1.25, -2.05, -0.55), (-1.1, -2.05, 0.6),
              (-0.2, -2.0, 1.25), (0.8, -1.9, 1.35), (1.6, -1.6, 1.55), (2.0, -1.15, 1.5)], 810, 0.95, 0.22)
    return c


def body():
    c = Component("body")
    c.spline([(0.0, -0.2, 0.0), (0.0, 0.3, 0.02), (0.0, 0.8, 0.0), (0.0, 1.3, -0.05)], 240, 0.85, 0.8)
    c.spline([(-0.28, -0.1, 0.0), (-0.22, 0.4, 0.0), (-0.3, 0.9, -0.02), (-0.45, 1.25, -0.05)], 150, 0.6, 0.55)
    c.spline([(0.28, -0.1, 0.0), (0.22, 0.4, 0.0), (0.3, 0.9, -0.02), (0.45, 1.25, -0.05)], 150, 0.6, 0.55)
    c.spline([(-0.62, 1.28, -0.05), (0.0, 1.36, -0.05), (0.62, 1.28, -0.05)], 100, 0.45)
    # The right arm hangs down and rests on the hip.
    c.spline([(0.62, 1.28, -0.05), (0.82, 0.75, -0.05), (0.8, 0.25, 0.2), (0.45, 0.05, 0.35)], 200, 0.4, 0.3)
    return c


def chest():
    c = Component("chest")
    for x in (-0.22, 0.22):
        c.spline([(x, 0.88, 0.12), (x * 1.08, 0.84, 0.3)], 20, 0.5, 0.42)
    return c


def left_hand():
    c = Component("left_hand")
    shoulder, elbow, wrist = (-0.62, 1.28, -0.05), (-1.05, 0.75, 0.35), (-1.25, 1.2, 0.85)
    c.spline([shoulder, (-0.85, 1.0, 0.12), elbow, (-1.18, 0.95, 0.62), wrist], 250, 0.42, 0.28)
    palm = (-1.3, 1.4, 1.0)
    c.spline([wrist, palm], 50, 0.3, 0.3)
    for i, (dx, dz, length, n) in enumerate([(-0.16, 0.0, 0.3, 40), (-0.06, 0.03, 0.36, 45), (0.04, 0.03, 0.38, 45),
                                              (0.13, 0.0, 0.34, 45), (0.2, -0.1, 0.24, 45)]):
        base = (palm[0] + dx, palm[1] + 0.05, palm[2] + dz)
        bend = 0.08 * (i - 2)
        tip = (base[0] + dx * 0.6 + bend, base[1] + length, base[2] + 0.08)
        mid = tuple((a + b) / 2 + o for a, b, o in zip(base, tip, (0.0, 0.0, 0.05)))
        c.spline([base, mid, tip], n, 0.14, 0.1)
    c.spline([(-1.2, 1.3, 0.95), (-1.1, 1.45, 1.0), (-1.05, 1.55, 1.05)], 50, 0.16, 0.11)
    return c


def neck():
    c = Component("neck")
    c.spline([(0.0, 1.3, -0.04), (0.0, 1.72, 0.02)], 20, 0.55, 0.5)
    return c


HEAD_CENTER = (0.0, 2.05, 0.0)


def head():
    c = Component("head")
    x0, y0, z0 = HEAD_CENTER
    c.spline([(x0, y0 - 0.3, z0 + 0.12), (x0, y0, z0 + 0.05), (x0, y0 + 0.32, z0 - 0.05)], 300, 0.95, 0.9)
    c.spline([(x0, y0 + 0.02, z0 + 0.36), (x0, y0 - 0.08, z0 + 0.42)], 30, 0.13, 0.1)
    for side in (-1, 1):
        c.spline([(x0 + 0.18 * side, y0 + 0.05, z0 + 0.22), (x0 + 0.2 * side, y0 - 0.17, z0 + 0.18)], 100, 0.3)
    c.spline([(x0 - 0.2, y0 + 0.15, z0 + 0.3), (x0, y0 + 0.17, z0 + 0.33), (x0 + 0.2, y0 + 0.15, z0 + 0.3)], 80, 0.11)
    c.spline([(x0 - 0.15, y0 - 0.25, z0 + 0.2), (x0, y0 - 0.36, z0 + 0.26), (x0 + 0.15, y0 - 0.25, z0 + 0.2)], 90, 0.2)
    return c


def hair():
    """93 snakes of 70 points, rooted on the back and top of the scalp, writhing outwards."""
    c = Component("hair")
    x0, y0, z0 = HEAD_CENTER
    n = 93
    golden = math.pi * (3 - math.sqrt(5))
    for i in range(n):
        # Fibonacci points on the part of the scalp above the ears and behind the face.
        y = 1 - 1.3 * (i + 0.5) / n
        r = math.sqrt(max(0.0, 1 - y * y))
        a = golden * i
        d = (r * math.cos(a), y, r * math.sin(a))
        if d[2] > 0.55:  # keep the face clear
            d = (d[0], d[1], -d[2] * 0.5)
        norm = math.sqrt(sum(v * v for v in d))
        d = tuple(v / norm for v in d)
        root = (x0 + 0.34 * d[0], y0 + 0.34 * d[1], z0 + 0.34 * d[2])
        # A side vector to writhe along.
        side = (d[1], -d[0], 0.0) if abs(d[2]) < 0.9 else (0.0, d[2], -d[1])
        sn = math.sqrt(sum(v * v for v in side)) or 1.0
        side = tuple(v / sn for v in side)
        length = 1.0 + 0.35 * math.sin(i * 1.7)
        ctrl = []
        for k in range(6):
            t = k / 5
            wave = 0.14 * math.sin(t * 2.6 * math.pi + i)
            droop = -0.35 * t * t
            ctrl.append(tuple(rt + dv * length * t + sv * wave + (droop if j == 1 else 0.0)
                              for j, (rt, dv, sv) in enumerate(zip(root, d, side))))
        c.spline(ctrl, 70, 0.2, 0.07)
    return c


HEADER = """// Generated by scenes/tools/make_medusa.py; edit that script, not this file.
"""


def medusa():
    comps = [tail(), body(), chest(), left_hand(), neck(), head(), hair()]
    parts = "\n".join(component_ron(c) for c in comps)
    return (HEADER + "// Medusa, after the caching paper (section 6.1): 9490 points in seven named components,\n"
            "// each a blend of splines of points under a 128³ cache.\n"
            "Scene(\n"
            "    camera: Camera(eye: (2.3, 1.3, 7.9), target: (0.1, 0.3, 0.0), up: (0.0, 1.0, 0.0), fov_y: 40.0),\n"
            "    size: (640, 480),\n    threshold: 0.5,\n    background: (0.05, 0.055, 0.065),\n"
            f"    model: Blend([\n{parts}\n    ]),\n)\n")


def hair_point():
    h = hair()
    x0, y0, z0 = HEAD_CENTER
    return (HEADER + "// Table 2's point/hair test: Medusa's hair alone, and a small point `probe` to move through it.\n"
            "Scene(\n"
            f"    camera: Camera(eye: (2.2, 2.8, 4.2), target: ({x0}, {y0 + 0.1}, {z0}), up: (0.0, 1.0, 0.0), fov_y: 40.0),\n"
            "    size: (640, 480),\n    threshold: 0.5,\n"
            "    model: Blend([\n" + component_ron(h) + "\n"
            f'        Named("probe", Point(center: ({x0 + 0.9:.4f}, {y0 + 0.3:.4f}, {z0 - 0.2:.4f}), radius: 0.3, color: (0.85, 0.25, 0.2))),\n'
            "    ]),\n)\n")


if __name__ == "__main__":
    with open("scenes/medusa.ron", "w") as f:
        f.write(medusa())
    with open("scenes/hair_point.ron", "w") as f:
        f.write(hair_point())
