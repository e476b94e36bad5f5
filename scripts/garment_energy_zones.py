#!/usr/bin/env python3
"""Where a simulated garment holds its membrane energy, and how it is stretched there.

    python3 scripts/garment_energy_zones.py REFERENCE.ply POSED.ply [CLOTH_THICKNESS_M REINFORCED_THICKNESS_M]

Both files are `kgd simulate ... --out F.ply` output of the same garment (with `--frames`, F_frame_01.ply
and the last frame, for example). REFERENCE gives each face's area and directions: the first frame of a
motion is close to the garment's rest shape. Each face's energy is its energy density (the PLY's
energy_density_Pa) times its area in REFERENCE times its material's thickness (default the paper's
cloth 0.27 mm and reinforcement 0.35 mm, by the PLY's design bit).

The garment is cut into fifths of its height in REFERENCE (0 = lowest) and into front and back (face
centre's z above or below the mean z of the vertices). Each zone prints its energy (J), its area in
REFERENCE (m^2), and the energy-weighted mean of each face's larger principal stretch from REFERENCE to
POSED, how vertical its direction is in REFERENCE (|y|: 1 along the body, 0 around it), and the smaller
principal stretch.
"""
import struct
import sys

from skin_directions import principal_stretches


def read_ply(path):
    """kgd's binary PLY: vertices (x, y, z doubles), faces (uchar 3, three ints, uchar design, double density)."""
    data = open(path, "rb").read()
    end = data.index(b"end_header\n")
    header = data[:end].decode()
    expected = ["property list uchar int vertex_indices", "property uchar design", "property double energy_density_Pa"]
    if "binary_little_endian" not in header or any(p not in header for p in expected):
        sys.exit(f"{path}: not a kgd simulate PLY (binary, with design and energy_density_Pa per face)")
    nv = int(header.split("element vertex ")[1].split()[0])
    nf = int(header.split("element face ")[1].split()[0])
    i = end + len(b"end_header\n")
    vertices = [struct.unpack_from("<3d", data, i + 24 * k) for k in range(nv)]
    i += 24 * nv
    faces, design, density = [], [], []
    for _ in range(nf):
        faces.append(struct.unpack_from("<3i", data, i + 1))
        design.append(data[i + 13])
        density.append(struct.unpack_from("<d", data, i + 14)[0])
        i += 22
    return vertices, faces, design, density


def main():
    if len(sys.argv) not in (3, 5):
        sys.exit(__doc__)
    thickness = (0.27e-3, 0.35e-3) if len(sys.argv) == 3 else (float(sys.argv[3]), float(sys.argv[4]))
    rv, faces, design, _ = read_ply(sys.argv[1])
    pv, pfaces, _, density = read_ply(sys.argv[2])
    if len(rv) != len(pv) or faces != pfaces:
        sys.exit("the two files are not the same garment (vertex count or faces differ)")
    ys = [v[1] for v in rv]
    y_lo, y_hi = min(ys), max(ys)
    z_mean = sum(v[2] for v in rv) / len(rv)
    zones = {}
    total = 0.0
    for f, face in enumerate(faces):
        stretches = principal_stretches(rv, pv, face)
        if stretches is None:  # degenerate in REFERENCE: no area, no energy
            continue
        big, small, direction, area = stretches
        energy = density[f] * area * thickness[1 if design[f] else 0]
        total += energy
        centre = tuple(sum(rv[k][i] for k in face) / 3 for i in range(3))
        fifth = min(4, int(5 * (centre[1] - y_lo) / (y_hi - y_lo)))
        side = "front" if centre[2] > z_mean else "back"
        z = zones.setdefault((fifth, side), [0.0, 0.0, 0.0, 0.0, 0.0])
        z[0] += energy
        z[1] += area
        z[2] += energy * big
        z[3] += energy * abs(direction[1])
        z[4] += energy * small
    print(f"membrane energy {total:.4f} J")
    print("height   side   energy (J)  area (m^2)  larger stretch  |y|   smaller stretch")
    for fifth in range(5):
        for side in ("front", "back"):
            e, a, big, vertical, small = zones.get((fifth, side), [0.0] * 5)
            w = 1.0 / e if e > 0 else 0.0
            print(f"{fifth / 5:.1f}-{(fifth + 1) / 5:.1f}  {side:5s}  {e:10.3f}  {a:10.3f}  {big * w:14.3f}  {vertical * w:4.2f}  {small * w:15.3f}")


if __name__ == "__main__":
    main()
