#!/usr/bin/env python3
"""The tables of docs/RESULTS.md that `make study` measures, from scripts/design_study.sh's outputs.

  python3 scripts/study_tables.py BLOCK OUT_DIR

prints BLOCK's Markdown table (the body of its generated block: scripts/generated_block.py) from the
files study_scene (scripts/study_scene.sh) wrote into OUT_DIR for the seven built-in scenes: NAME.table.txt
(`kgd designs`), NAME.baselines.txt (`kgd baselines`, the sleeves), NAME.frames.txt (`kgd evaluate`).
Exit 2, printing nothing, when a scene's files are absent or hold no iteration.
BLOCK: results-table-1 (beside the paper's Table 1), results-curves (every 20 iterations).
"""
import os
import sys

# scene: (name, paper's vertices, BESO steps, time per iteration on a GPU, density increase), Table 1 of the paper.
PAPER = {
    "arm_flexion": ("Arm flexion", "7.1k", 150, "10.65 s", "1.97x"),
    "arm_extension": ("Arm extension", "7.1k", 180, "10.88 s", "2.26x"),
    "knee_flexion": ("Knee flexion", "3.2k", 180, "10.47 s", "2.16x"),
    "knee_extension": ("Knee extension", "3.2k", 150, "10.24 s", "2.91x"),
    "slouch": ("Slouch", "28.3k", 200, "15.80 s", "2.15x"),
    "crouch": ("Crouch", "9.5k", 150, "11.70 s", "2.32x"),
    "lunge": ("Lunge", "9.5k", 180, "11.55 s", "3.02x"),
}
SLEEVES = ("arm_flexion", "arm_extension", "knee_flexion", "knee_extension")


class Missing(Exception):
    pass


def read_lines(path):
    if not os.path.exists(path):
        raise Missing(path)
    with open(path) as f:
        return f.read().splitlines()


def designs(out, scene):
    """(vertices, rows) of `kgd designs`: rows of (iteration, area %, ratio, total_s)."""
    lines = read_lines(os.path.join(out, f"{scene}.table.txt"))
    vertices = int(lines[0].split(": ")[1].split(" vertices")[0])
    rows = []
    for l in lines[2:]:
        f = l.split()
        if len(f) == 10 and f[0].isdigit():
            rows.append((int(f[0]), float(f[1]), float(f[6]), float(f[9])))
    if not rows:
        raise Missing(f"{scene}: no iteration")
    return vertices, rows


def last_ratio_over_frames(out, scene):
    rows = [l.split() for l in read_lines(os.path.join(out, f"{scene}.frames.txt"))]
    rows = [f for f in rows if len(f) >= 6 and f[0].isdigit()]
    if not rows:
        raise Missing(f"{scene}.frames.txt: no frame")
    return float(rows[-1][5])


def line_and_x(out, scene):
    """Line's and X's reinforced energy over the optimized design's (`kgd baselines`' last column)."""
    vs = {}
    for l in read_lines(os.path.join(out, f"{scene}.baselines.txt")):
        f = l.split()
        if len(f) >= 5 and f[0] in ("line", "x"):
            vs[f[0]] = float(f[4])
    if len(vs) != 2:
        raise Missing(f"{scene}.baselines.txt: Line and X")
    return f"{vs['line']:.2f} / {vs['x']:.2f}"


def table_1(out):
    rows = ["| scene | vertices paper / kgd | BESO steps paper / kgd | time per iteration paper (GPU) / kgd | "
            "density increase paper / kgd | kgd, put on in the pose | Line / X vs optimized (reinforced energy) |",
            "|---|---|---|---|---|---|---|"]
    for scene, (name, p_vertices, p_steps, p_time, p_ratio) in PAPER.items():
        vertices, its = designs(out, scene)
        per_iteration = sum(r[3] for r in its) / len(its)
        baselines = line_and_x(out, scene) if scene in SLEEVES else "(three bands: no Line/X)"
        rows.append(f"| {name} | {p_vertices} / {vertices:,} | {p_steps} / {len(its)} | {p_time} / {per_iteration:.3f} s | "
                    f"{p_ratio} / **{its[-1][2]:.2f}x** | {last_ratio_over_frames(out, scene):.2f}x | {baselines} |")
    return rows


def curves(out):
    runs = {scene: designs(out, scene)[1] for scene in PAPER}
    cell = lambda r: f"{r[2]:.3f} ({r[1]:.0f} %)"
    rows = ["| iteration | " + " | ".join(p[0].lower() for p in PAPER.values()) + " |",
            "|---|" + "---|" * len(PAPER)]
    last = max(r[-1][0] for r in runs.values())
    for k in range(0, last + 1, 20):
        at = [next((cell(r) for r in its if r[0] == k), "") for its in runs.values()]
        rows.append(f"| {k} | " + " | ".join(at) + " |")
    rows.append("| end | " + " | ".join(f"{cell(its[-1])} at {its[-1][0]}" for its in runs.values()) + " |")
    return rows


TABLES = {"results-table-1": table_1, "results-curves": curves}


def main(argv):
    if len(argv) != 2 or argv[0] not in TABLES:
        print(__doc__, file=sys.stderr)
        return 1
    try:
        rows = TABLES[argv[0]](argv[1])
    except (Missing, ValueError, IndexError) as e:
        print(f"scripts/study_tables.py: {argv[0]}: {e}", file=sys.stderr)
        return 2
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
