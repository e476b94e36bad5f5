#!/usr/bin/env python3
"""The table of docs/RESULTS.md, "On the MakeHuman bodies", from scripts/makehuman_study.sh's outputs.

  python3 scripts/makehuman_tables.py OUT_DIR

prints the body of the generated block results-makehuman (scripts/generated_block.py) from the files
study_scene (scripts/study_scene.sh) wrote into OUT_DIR for the seven motions, read as
scripts/study_tables.py reads the built-in study's. Exit 2, printing nothing, when a motion's files are
absent or hold no iteration.
"""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import study_tables  # noqa: E402

MOTIONS = ("arm_flexion", "arm_extension", "knee_flexion", "knee_extension", "slouch", "crouch", "lunge")
NAMES = {"arm_flexion": "Arm flexion", "arm_extension": "Arm extension", "knee_flexion": "Knee flexion",
         "knee_extension": "Knee extension", "slouch": "Slouch", "crouch": "Crouch", "lunge": "Lunge"}
SLEEVES = ("arm_flexion", "arm_extension", "knee_flexion", "knee_extension")


def reinforced_energies(out, motion):
    """The optimized design's, Line's and X's reinforced energy (`kgd baselines`' reinforced_J column)."""
    vs = {}
    for l in study_tables.read_lines(os.path.join(out, f"{motion}.baselines.txt")):
        f = l.split()
        if len(f) >= 5 and f[0] in ("optimized", "line", "x"):
            vs[f[0]] = float(f[2])
    if len(vs) != 3:
        raise study_tables.Missing(f"{motion}.baselines.txt: optimized, Line and X")
    return f"{vs['optimized']:.3f} / {vs['line']:.3f} / {vs['x']:.3f} J"


def table(out):
    rows = ["| scene | vertices | BESO steps | time per iteration | density increase | put on in the pose | "
            "Line / X vs optimized | reinforced energy, optimized / Line / X |",
            "|---|---|---|---|---|---|---|---|"]
    for motion in MOTIONS:
        vertices, its = study_tables.designs(out, motion)
        per_iteration = sum(r[3] for r in its) / len(its)
        if motion in SLEEVES:
            baselines = f"{study_tables.line_and_x(out, motion)} | {reinforced_energies(out, motion)}"
        else:
            baselines = "(three bands) | "
        rows.append(f"| {NAMES[motion]} | {vertices:,} | {len(its)} | {per_iteration:.3f} s | **{its[-1][2]:.2f}x** | "
                    f"{study_tables.last_ratio_over_frames(out, motion):.2f}x | {baselines} |")
    return rows


def main(argv):
    if len(argv) != 1:
        print(__doc__, file=sys.stderr)
        return 1
    try:
        rows = table(argv[0])
    except (study_tables.Missing, ValueError, IndexError) as e:
        print(f"scripts/makehuman_tables.py: {e}", file=sys.stderr)
        return 2
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
