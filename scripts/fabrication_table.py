#!/usr/bin/env python3
"""The table of docs/FABRICATION.md, "Today's figures", from scripts/fabrication_previews.sh's outputs.

  python3 scripts/fabrication_table.py OUT_DIR

prints the body of the generated block fabrication-figures (scripts/generated_block.py) from the
reports `kgd export --json` wrote into OUT_DIR (arm_flexion.export.json, knee_flexion.export.json,
pull_test_line.export.json) and, when present, the MakeHuman sleeve's pattern as
`core/fabrication/pattern_test` prints it (makehuman_pattern.txt; that row is left out when the test
skipped). Every piece's sew line is given by its largest turn between consecutive segments away from
its corners and its farthest point from the outline on the body. Exit 2, printing nothing, when a
report is absent or unreadable.
"""
import json
import os
import re
import sys

# (report file, row label, from a design file: its iteration is shown)
EXPORTS = (("arm_flexion", "arm flexion", True), ("knee_flexion", "knee flexion", True),
           ("pull_test_line", "pull test, Line (`kgd export pull_test_line`)", False))
PIECE = re.compile(r"^makehuman sleeve_arm piece \d+: .*area distortion mean ([\d.]+) % max ([\d.]+) %; "
                   r"angle mean ([\d.]+) max ([\d.]+) deg$")
SEAM = re.compile(r"^makehuman sleeve_arm seam \d+: sides ([\d.]+) and ([\d.]+) mm$")
SEW = re.compile(r"^makehuman sleeve_arm piece \d+ sew line: \d+ points, turning max ([\d.]+) deg away from \d+ corners "
                 r"\(outline ([\d.]+)\), deviation max ([\d.]+) mm$")


class Missing(Exception):
    pass


def report(out, name):
    path = os.path.join(out, f"{name}.export.json")
    try:
        with open(path) as f:
            return json.load(f)
    except (OSError, ValueError) as e:
        raise Missing(f"{path}: {e}")


def joined(items, cell):
    return "; ".join(cell(i) for i in items) if items else "–"


def export_row(label, r, show_iteration):
    pieces = r["pieces"]
    return (f"| {label} | {r['iteration'] if show_iteration else '–'} | "
            f"{r['density_ratio']:.3f} → {r['cleaned']['density_ratio']:.3f} | {len(pieces)} | "
            + joined(pieces, lambda p: f"{100 * p['area_distortion_mean']:.2f} % / {100 * p['area_distortion_max']:.2f} %") + " | "
            + joined(pieces, lambda p: f"{p['angle_distortion_mean_deg']:.2f} / {p['angle_distortion_max_deg']:.1f}") + " | "
            + joined(pieces, lambda p: f"{p['sew_line_turning_max_deg']:.1f} / {p['sew_line_deviation_max_mm']:.2f}") + " | "
            + joined(r["seams"], lambda s: f"{s['side_a_mm']:.2f} / {s['side_b_mm']:.2f}") + " | "
            f"{len(r['patches'])} | {100 * r['sheet_usage']:.0f} % |")


def makehuman_row(out):
    path = os.path.join(out, "makehuman_pattern.txt")
    if not os.path.exists(path):
        return None
    with open(path) as f:
        lines = f.read().splitlines()
    pieces = [m.groups() for m in map(PIECE.match, lines) if m]
    seams = [m.groups() for m in map(SEAM.match, lines) if m]
    sew = [m.groups() for m in map(SEW.match, lines) if m]
    if not pieces or len(sew) != len(pieces):
        return None
    return ("| MakeHuman arm sleeve (pattern only, seams by length) | – | – | " + f"{len(pieces)} | "
            + "; ".join(f"{float(a):.2f} % / {float(b):.2f} %" for a, b, _, _ in pieces) + " | "
            + "; ".join(f"{float(c):.2f} / {float(d):.1f}" for _, _, c, d in pieces) + " | "
            + "; ".join(f"{float(t):.1f} / {float(d):.2f}" for t, _, d in sew) + " | "
            + ("; ".join(f"{float(a):.2f} / {float(b):.2f}" for a, b in seams) or "–") + " | – | – |")


def table(out):
    rows = ["| scene | iteration | density ratio, stored → cleaned | pieces | area distortion per piece, mean / max | "
            "angle distortion, mean / max (deg) | sew line: largest turn away from corners (deg) / farthest from the outline "
            "on the body (mm) | seam sides along the sew lines (mm) | patches | sheet usage |",
            "|---|---|---|---|---|---|---|---|---|---|"]
    reports = [(label, report(out, name), shown) for name, label, shown in EXPORTS]
    rows += [export_row(label, r, shown) for label, r, shown in reports[:2]]
    makehuman = makehuman_row(out)
    if makehuman:
        rows.append(makehuman)
    rows.append(export_row(*reports[2]))
    return rows


def main(argv):
    if len(argv) != 1:
        print(__doc__, file=sys.stderr)
        return 1
    try:
        rows = table(argv[0])
    except (Missing, KeyError, TypeError) as e:
        print(f"scripts/fabrication_table.py: {e}", file=sys.stderr)
        return 2
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
