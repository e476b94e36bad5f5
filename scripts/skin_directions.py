#!/usr/bin/env python3
"""How the skin under a garment region stretches from a body's rest pose to a posed one, by direction.

    python3 scripts/skin_directions.py REST.obj POSED.obj REGION.txt [ATTACH.txt]

REST and POSED share their topology (kgd body, kgd scene export, or ../shared/bodies/makehuman);
REGION lists the garment's body faces (0-based, one per line). For each quarter of the region's
height (0 = lowest) and each side (front/back: z above or below 0; left/right: x above or below 0) it
prints the area-weighted mean of each face's larger and smaller principal stretch (rest -> posed), their
product (the area stretch) and how vertical the larger one's direction is in the rest pose (|y|: 1 along
the body, 0 around it). The area stretch alone can hide skin pressed along the body and spread around it.

With ATTACH (the region's attachment faces), it also prints, for the ends other than the highest one
(the waistband), the shortest path over the region's edges from the waistband to each end's vertices,
posed over rest, by direction round the end's centre (front = +z): the length a garment must span there.
"""
import heapq
import math
import sys


def load_obj(path):
    vertices, faces = [], []
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                vertices.append(tuple(map(float, line.split()[1:4])))
            elif line.startswith("f "):
                faces.append([int(t.split("/")[0]) - 1 for t in line.split()[1:]])
    return vertices, faces


def load_indices(path):
    with open(path) as f:
        return [int(line) for line in f if line.strip()]


def sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def dot(a, b):
    return sum(a[i] * b[i] for i in range(3))


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def principal_stretches(rest, posed, face):
    """Larger and smaller principal stretch of the face, and the larger one's rest direction (3D)."""
    a, b, c = face
    e1, e2 = sub(rest[b], rest[a]), sub(rest[c], rest[a])
    n = cross(e1, e2)
    area = 0.5 * math.sqrt(dot(n, n))
    if area <= 0:
        return None
    u = [x / math.sqrt(dot(e1, e1)) for x in e1]
    w = cross([x / (2 * area) for x in n], u)
    dm = [[dot(e1, u), dot(e2, u)], [dot(e1, w), dot(e2, w)]]
    det = dm[0][0] * dm[1][1] - dm[0][1] * dm[1][0]
    inv = [[dm[1][1] / det, -dm[0][1] / det], [-dm[1][0] / det, dm[0][0] / det]]
    p1, p2 = sub(posed[b], posed[a]), sub(posed[c], posed[a])
    grad = [[p1[i] * inv[0][j] + p2[i] * inv[1][j] for j in range(2)] for i in range(3)]
    cg = [[sum(grad[k][i] * grad[k][j] for k in range(3)) for j in range(2)] for i in range(2)]
    tr, dt = cg[0][0] + cg[1][1], cg[0][0] * cg[1][1] - cg[0][1] ** 2
    disc = math.sqrt(max(tr * tr / 4 - dt, 0))
    large = tr / 2 + disc
    if abs(cg[0][1]) > 1e-14:
        ev = [cg[0][1], large - cg[0][0]]
    else:
        ev = [1.0, 0.0] if cg[0][0] >= cg[1][1] else [0.0, 1.0]
    norm = math.hypot(*ev)
    direction = [(ev[0] * u[i] + ev[1] * w[i]) / norm for i in range(3)]
    return math.sqrt(large), math.sqrt(max(tr / 2 - disc, 0)), direction, area


def stretch_by_part(rest, posed, faces, region):
    ys = [rest[v][1] for f in region for v in faces[f]]
    y0, y1 = min(ys), max(ys)
    parts = {}
    for f in region:
        s = principal_stretches(rest, posed, faces[f])
        if s is None:
            continue
        large, small, direction, area = s
        centre = [sum(rest[v][i] for v in faces[f]) / 3 for i in range(3)]
        quarter = min(3, int(4 * (centre[1] - y0) / (y1 - y0)))
        side = ("front" if centre[2] > 0 else "back") + (" left" if centre[0] > 0 else " right")
        acc = parts.setdefault((quarter, side), [0.0, 0.0, 0.0, 0.0])
        acc[0] += area * large
        acc[1] += area * small
        acc[2] += area * abs(direction[1])
        acc[3] += area
    print("quarter side         larger  smaller  area   |y| of larger")
    for (quarter, side), (large, small, vertical, area) in sorted(parts.items()):
        print(f"{quarter:7d} {side:12s} {large / area:7.3f} {small / area:8.3f} {large * small / area ** 2:6.3f} {vertical / area:7.2f}")


def span_to_ends(rest, posed, faces, region, attach):
    neighbours = {}
    for f in region:
        t = faces[f]
        for i in range(3):
            a, b = t[i], t[(i + 1) % 3]
            neighbours.setdefault(a, set()).add(b)
            neighbours.setdefault(b, set()).add(a)
    attached = {v for f in attach for v in faces[f]}
    ends, seen = [], set()
    for v in attached:
        if v in seen:
            continue
        piece, stack = [], [v]
        seen.add(v)
        while stack:
            u = stack.pop()
            piece.append(u)
            for w in neighbours.get(u, ()):
                if w in attached and w not in seen:
                    seen.add(w)
                    stack.append(w)
        ends.append(piece)
    ends.sort(key=lambda e: -sum(rest[v][1] for v in e) / len(e))

    def distances(x, sources):
        d = {v: 0.0 for v in sources}
        heap = [(0.0, v) for v in sources]
        heapq.heapify(heap)
        while heap:
            dd, u = heapq.heappop(heap)
            if dd > d[u]:
                continue
            for w in neighbours[u]:
                nd = dd + math.dist(x[u], x[w])
                if nd < d.get(w, math.inf):
                    d[w] = nd
                    heapq.heappush(heap, (nd, w))
        return d

    d_rest, d_posed = distances(rest, ends[0]), distances(posed, ends[0])
    names = ["front", "front-side", "side", "back-side", "back"]
    for k, end in enumerate(ends[1:], 1):
        centre = [sum(rest[v][i] for v in end) / len(end) for i in range(3)]
        bins = {}
        for v in end:
            angle = abs(math.degrees(math.atan2(rest[v][0] - centre[0], rest[v][2] - centre[2])))
            bins.setdefault(min(4, int((angle + 22.5) // 45)), []).append(d_posed[v] / d_rest[v])
        row = ", ".join(f"{names[b]} {sum(r) / len(r):.3f}" for b, r in sorted(bins.items()))
        print(f"waistband to end {k} (rest x {centre[0]:+.3f} m), posed / rest: {row}")


def main():
    if len(sys.argv) not in (4, 5):
        sys.exit(__doc__)
    rest, faces = load_obj(sys.argv[1])
    posed, posed_faces = load_obj(sys.argv[2])
    if len(posed) != len(rest) or posed_faces != faces:
        sys.exit(f"{sys.argv[2]}: not the topology of {sys.argv[1]}")
    region = load_indices(sys.argv[3])
    bad = [f for f in region if not 0 <= f < len(faces)]
    if bad:
        sys.exit(f"{sys.argv[3]}: face {bad[0]} is not a face of {sys.argv[1]} ({len(faces)} faces)")
    stretch_by_part(rest, posed, faces, region)
    if len(sys.argv) == 5:
        span_to_ends(rest, posed, faces, region, load_indices(sys.argv[4]))


if __name__ == "__main__":
    main()
