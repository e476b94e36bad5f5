#!/usr/bin/env python3
"""Writes rest.obj and deformed.obj beside this script: a small torso-like closed surface (metres, y up,
+z the front), mirror symmetric about x = 0, and the same surface bent forward above the waist.

The torso: 31 elliptical rings of 40 vertices from y = 0.84 to 1.44 m every 0.02 m (half-width 0.16 m and
half-depth 0.11 m, narrower at the waist, y = 1.05), each end closed by a fan to a centre vertex a little
beyond the last ring; 2,480 faces. Quads are split along the diagonal that makes the triangulation
mirror symmetric (vertex k of a ring mirrors to vertex 40 - k), so every face has a mirror face.
The deformed pose: a forward bend of 35 degrees spread over y = 1.00..1.25 m (an arc about an axis
parallel to x in front of the body) and straight above it, which stretches the back (by up to 1 + k z,
k = 0.61 rad / 0.25 m) and shortens the front.

    python3 tests/data/studio/make_body.py     (the standard library only; deterministic)
"""
import math
import os

N = 40  # vertices per ring (even: vertices 0 and N/2 lie on the plane x = 0)
Y = [0.84 + 0.02 * j for j in range(31)]  # ring heights, m
CAP = 0.03  # m the end vertices stand beyond the last rings
BEND_Y0, BEND_LENGTH, BEND_ANGLE = 1.00, 0.25, math.radians(35.0)


def half_width(y):
    return 0.16 - 0.025 * math.exp(-(((y - 1.05) / 0.12) ** 2))


def half_depth(y):
    return 0.11 - 0.015 * math.exp(-(((y - 1.05) / 0.12) ** 2))


def rest_torso():
    vertices = []
    for y in Y:
        a, b = half_width(y), half_depth(y)
        ring = []
        for k in range(N):
            if k <= N // 2:
                t = 2 * math.pi * k / N
                x = 0.0 if k in (0, N // 2) else a * math.sin(t)
                ring.append((x, y, b * math.cos(t)))
            else:  # the mirror image of vertex N - k, exactly
                x, yy, z = ring[N - k]
                ring.append((-x, yy, z))
        vertices += ring
    bottom, top = len(vertices), len(vertices) + 1
    vertices += [(0.0, Y[0] - CAP, 0.0), (0.0, Y[-1] + CAP, 0.0)]

    def v(j, k):
        return j * N + k % N

    faces = []
    for j in range(len(Y) - 1):
        for k in range(N):
            v00, v01, v10, v11 = v(j, k), v(j, k + 1), v(j + 1, k), v(j + 1, k + 1)
            if k < N // 2:  # diagonal v00-v11; its mirror quad takes v01-v10
                faces += [(v00, v01, v11), (v00, v11, v10)]
            else:
                faces += [(v00, v01, v10), (v01, v11, v10)]
    last = len(Y) - 1
    for k in range(N):
        faces.append((bottom, v(0, k + 1), v(0, k)))
        faces.append((top, v(last, k), v(last, k + 1)))
    return vertices, faces


def bend(x):
    """The forward bend: the spine (x = z = 0) above BEND_Y0 follows an arc of radius R towards +z."""
    out = list(x)
    k = BEND_ANGLE / BEND_LENGTH
    r = 1.0 / k
    for i, (px, py, pz) in enumerate(x):
        s = py - BEND_Y0
        if s <= 0:
            continue
        phi = k * min(s, BEND_LENGTH)
        ny = BEND_Y0 + (r - pz) * math.sin(phi)
        nz = r - (r - pz) * math.cos(phi)
        if s > BEND_LENGTH:  # straight on along the spine's direction at the arc's end
            ny += (s - BEND_LENGTH) * math.cos(BEND_ANGLE)
            nz += (s - BEND_LENGTH) * math.sin(BEND_ANGLE)
        out[i] = (px, ny, nz)
    return out


def write_obj(path, x, faces, comment):
    with open(path, "w") as f:
        f.write(f"# {comment}\n# written by make_body.py\n")
        for p in x:
            f.write("v %.9f %.9f %.9f\n" % tuple(p))
        for t in faces:
            f.write("f %d %d %d\n" % tuple(i + 1 for i in t))


def sub(a, b):
    return tuple(p - q for p, q in zip(a, b))


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def check(x, faces):
    # Closed and consistently oriented: every directed edge once, and its reverse once.
    edges = {}
    for t in faces:
        for a, b in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
            assert (a, b) not in edges, "an edge used twice in one direction"
            edges[(a, b)] = True
    assert all((b, a) in edges for (a, b) in edges), "not closed"
    volume = sum(sum(p * q for p, q in zip(x[a], cross(x[b], x[c]))) for a, b, c in faces) / 6.0
    assert volume > 0, "faces point inwards"
    # Mirror symmetric: every face centroid's image about x = 0 is another face's centroid.
    centroids = [tuple(sum(x[i][d] for i in t) / 3.0 for d in range(3)) for t in faces]
    known = {tuple(round(v, 9) for v in c) for c in centroids}
    for c in centroids:
        assert tuple(round(v, 9) for v in (-c[0], c[1], c[2])) in known or \
            min(math.dist((-c[0], c[1], c[2]), o) for o in centroids) < 1e-9, c
    return volume


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    x, faces = rest_torso()
    bent = bend(x)
    v_rest, v_bent = check(x, faces), check(bent, faces)
    write_obj(os.path.join(here, "rest.obj"), x, faces, "studio test torso, rest pose (m)")
    write_obj(os.path.join(here, "deformed.obj"), bent, faces, "studio test torso bent forward 35 degrees above y = 1.00 m (m)")
    print(f"{len(x)} vertices, {len(faces)} faces; volume {v_rest:.5f} m^3 at rest, {v_bent:.5f} m^3 bent")


if __name__ == "__main__":
    main()
