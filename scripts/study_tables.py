#!/usr/bin/env python3
"""The tables of docs/RESULTS.md and docs/PERFORMANCE.md that `make study` measures, from
scripts/design_study.sh's outputs.

  python3 scripts/study_tables.py BLOCK OUT_DIR
  python3 scripts/study_tables.py doc BLOCK      the file BLOCK is written into

prints BLOCK's Markdown (the body of its generated block: scripts/generated_block.py) from the files
study_scene (scripts/study_scene.sh) wrote into OUT_DIR, one set per run (a built-in scene, or one with a
flag of `kgd design`: RUN = SCENE+FLAG, e.g. arm_brace+resist-only): RUN.jsonl (`kgd design`'s lines),
RUN.wall_s (its wall time), RUN.table.txt (`kgd designs`), RUN.baselines.txt (`kgd baselines`, the
sleeves), RUN.frames.txt (`kgd evaluate`); OUT_DIR/runs.txt lists the runs this study made and finished,
OUT_DIR/scenes.txt is `kgd scenes` with nothing learned (the reference predictions).
Exit 2, printing nothing, when a run the block needs is not in runs.txt (a block is written only from
runs of one study) or its files are absent or hold no iteration.
BLOCK, docs/RESULTS.md: results-table-1 (beside the paper's Table 1), results-curves (every 20
iterations), results-roles (the scenes with an allowed motion, their resist-only twins, the symmetric
shirt); docs/PERFORMANCE.md: performance-motions (an iteration of K motions against one motion's),
performance-predicted (each run's wall time against the reference prediction of `kgd scenes`).
"""
import json
import math
import os
import statistics
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


# The scenes with an allowed motion (docs/MODEL.md, "Motions with roles"): each run with roles, its
# resist-only twin (`--resist-only`: the allowed motions' weights 0) and the shirt made symmetric.
ROLES = {"arm_brace": ("arm_brace", "arm_brace+resist-only"),
         "knee_brace": ("knee_brace", "knee_brace+resist-only"),
         "posture_shirt": ("posture_shirt", "posture_shirt+resist-only", "posture_shirt+symmetric")}
ROLE_RUNS = [run for runs in ROLES.values() for run in runs]
# A job of K motions beside the single-motion job on the same garment.
MOTION_PAIRS = (("arm_flexion", "arm_brace"), ("knee_flexion", "knee_brace"), ("slouch", "posture_shirt"))
ALLOWED_AT_MOST = 0.5     # the issue's target: allowed motions' reinforced energy at most half the resist-only twin's
RESISTED_AT_LEAST = 0.85  # and the resisted density ratio at least 85 % of the twin's


def command(run):
    """`kgd design` of a run: SCENE+FLAG+... -> kgd design SCENE --FLAG ..."""
    scene, *flags = run.split("+")
    return "kgd design " + scene + "".join(f" --{f}" for f in flags)


def design_run(out, run):
    """(iteration lines, done line) of `kgd design`'s JSON lines (RUN.jsonl); other lines are passed over."""
    its, done = [], None
    for l in read_lines(os.path.join(out, f"{run}.jsonl")):
        if not l.startswith("{"):
            continue
        j = json.loads(l)
        if j.get("event") == "done":
            done = j
        elif "iteration" in j:
            its.append(j)
    if done is None or not its:
        raise Missing(f"{run}.jsonl: no finished design")
    return its, done


def motions_at_end(out, run):
    return {m["name"]: m for m in design_run(out, run)[1]["motions"]}


def joules(v):
    return f"{v:.4f} J" if v >= 1e-3 else f"{v:.2e}".replace("e-0", "e-") + " J"


def faces(out, run):
    head = read_lines(os.path.join(out, f"{run}.table.txt"))[0]
    return int(head.split(" faces")[0].split()[-1])


def roles(out):
    rows = ["Each motion at the end of each run (`kgd designs FILE` prints them):", "",
            "| command | iterations | motion | role, weight | density ratio | reinforced energy |", "|---|---|---|---|---|---|"]
    for runs in ROLES.values():
        for run in runs:
            its, done = design_run(out, run)
            for k, m in enumerate(done["motions"]):
                first = f"`{command(run)}` | {done['iterations']}" if k == 0 else " | "
                rows.append(f"| {first} | {m['name']} | {m['role']}, {m['weight']:g} | {m['density_ratio']:.3f} | "
                            f"{joules(m['reinforced_energy_J'])} |")
    rows += ["", f"The targets of a scene with roles, each run against its resist-only twin: an allowed motion's reinforced "
             f"energy at most {ALLOWED_AT_MOST:g}x, a resisted motion's density ratio at least {100 * RESISTED_AT_LEAST:.0f} %:", "",
             "| scene | allowed motion: reinforced energy, with roles / resist-only | resisted motion: density ratio, with roles / resist-only "
             "| the resist-only design's density ratio in the allowed motion |", "|---|---|---|---|"]
    for scene, runs in ROLES.items():
        with_roles, twin = motions_at_end(out, runs[0]), motions_at_end(out, runs[1])
        allowed, resisted, left = [], [], []
        for name, m in with_roles.items():
            t = twin[name]
            if m["role"] == "allow":
                r = m["reinforced_energy_J"] / t["reinforced_energy_J"]
                allowed.append(f"{name}: {joules(m['reinforced_energy_J'])} / {joules(t['reinforced_energy_J'])} = **{r:.2f}x**, "
                               + ("met" if r <= ALLOWED_AT_MOST else "missed"))
                left.append(f"{name}: {100 * t['density_ratio']:.2f} %")
            else:
                q = m["density_ratio"] / t["density_ratio"]
                resisted.append(f"{name}: {m['density_ratio']:.3f} / {t['density_ratio']:.3f} = **{100 * q:.1f} %**, "
                                + ("met" if q >= RESISTED_AT_LEAST else "missed"))
        rows.append(f"| {scene} | {'; '.join(allowed)} | {'; '.join(resisted)} | {'; '.join(left)} |")
    free, symmetric = ROLES["posture_shirt"][0], ROLES["posture_shirt"][2]
    (_, d_free), (_, d_sym) = design_run(out, free), design_run(out, symmetric)
    rows += ["", f"What symmetry costs the shirt (`{command(symmetric)}` against `{command(free)}`):", "",
             "| motion | role | density ratio, unconstrained | density ratio, symmetric | symmetric / unconstrained |", "|---|---|---|---|---|"]
    sym = {m["name"]: m for m in d_sym["motions"]}
    for m in d_free["motions"]:
        s = sym[m["name"]]
        rows.append(f"| {m['name']} | {m['role']} | {m['density_ratio']:.3f} | {s['density_ratio']:.3f} | "
                    f"{100 * s['density_ratio'] / m['density_ratio']:.1f} % |")
    rows.append(f"| (iterations) | | {d_free['iterations']} | {d_sym['iterations']} | |")
    # The final designs as `kgd export` draws them (pattern.png: the pattern pieces, the reinforcement in blue).
    shown = [run for run in ROLE_RUNS if os.path.exists(os.path.join(out, f"{run}.export", "pattern.png"))]
    if shown:
        rows += ["", "The final designs on their pattern pieces (`kgd export FILE --out DIR`'s `pattern.png`: the design cleaned "
                 "of features under 3 mm, the reinforcement filled pale blue):", "",
                 "| scene | with roles | resist-only | symmetric |", "|---|---|---|---|"]
        for scene, runs in ROLES.items():
            cells = [f"![{run}](images/roles/{run}.png)" if run in shown else "" for run in runs]
            rows.append(f"| {scene} | " + " | ".join(cells + [""] * (3 - len(cells))) + " |")
    else:
        rows += ["", "(No pictures: `kgd export` wrote no preview.)"]
    return rows


def median_of(its, key, motion=None):
    """Median over iterations 1..N (iteration 0 is the cold solve) of a field, or of one motion's."""
    vs = [(it["motions"][motion] if motion is not None else it)[key] for it in its if it["iteration"] > 0]
    if not vs:
        raise Missing("no iteration after iteration 0")
    return statistics.median(vs)


def mean_of(its, key, motion=None):
    """Mean over iterations 1..N (iteration 0 is the cold solve) of a field, or of one motion's."""
    vs = [(it["motions"][motion] if motion is not None else it)[key] for it in its if it["iteration"] > 0]
    if not vs:
        raise Missing("no iteration after iteration 0")
    return statistics.mean(vs)


def motions_cost(out):
    rows = ["Each job of K motions beside the single-motion job on the same garment (the same faces and body; the motions "
            "differ), from `kgd design`'s JSON lines over the iterations after iteration 0 (the cold solve from the body): "
            "the whole iteration (`total_s`; mean, and median in brackets), the solve of the scene's own motion (the first: "
            "one motion's solve, `motions[0].simulation_s`), the iteration over it (K when every motion's solve costs the "
            "own one's and nothing else grows), the rest outside the solves (sensitivities of every motion in the "
            "objective, filter, update: what would grow were anything rebuilt per iteration), and each motion's solve "
            "(mean time, and mean Newton iterations per BESO iteration: over the whole run / over iterations 1-30).", "",
            "| job | K | faces | iterations | per iteration | against the single-motion job | own motion's solve | "
            "iteration / own solve | the rest | each motion: solve, Newton iterations (all / 1-30) | iteration 0 |",
            "|---|---|---|---|---|---|---|---|---|---|---|"]
    for single, several in MOTION_PAIRS:
        one = None
        for run in (single, several):
            its, done = design_run(out, run)
            per, per_median = mean_of(its, "total_s"), median_of(its, "total_s")
            own = mean_of(its, "simulation_s", 0)
            rest = per - mean_of(its, "simulation_s")
            k = len(its[-1]["motions"])
            early = [it for it in its if 0 < it["iteration"] <= 30]
            each = "; ".join(f"{m['name']} {mean_of(its, 'simulation_s', i):.3f} s, {mean_of(its, 'solver_iterations', i):.1f} / "
                             f"{mean_of(early, 'solver_iterations', i):.1f}" for i, m in enumerate(its[-1]["motions"]))
            against = "" if one is None else f"{per / one:.2f}x"
            one = per if one is None else one
            rows.append(f"| `{command(run)}` | {k} | {faces(out, run):,} | {done['iterations']} | {per:.3f} s ({per_median:.3f} s) | "
                        f"{against} | {own:.3f} s | **{per / own:.2f}** | {rest:.4f} s | {each} | {its[0]['total_s']:.2f} s |")
    return rows


def reference_predictions(out):
    """Standard preset's prediction (s) per built-in scene from `kgd scenes` with nothing learned (scenes.txt)."""
    lines = read_lines(os.path.join(out, "scenes.txt"))
    if not any("on the reference machine" in l for l in lines):
        raise Missing("scenes.txt: not the reference predictions (a machine factor was learned)")
    p = {}
    for l in lines[1:]:
        f = l.split()
        if len(f) >= 6 and f[5].count("/") == 2:
            p[f[0]] = float(f[5].split("/")[1])
    return p


def predicted(out):
    p = reference_predictions(out)
    rows = ["Every design job of the study: the wall time of `kgd design` (its scene read from a warm cache) against "
            "the standard preset's prediction `kgd scenes` shows with nothing learned (a `KGD_CACHE_DIR` of its own: "
            "the reference machine's rates); error = (predicted - measured) / measured. The prediction counts a scene's "
            "build in the set-up, and one motion per scene.", "",
            "| command | iterations | reference prediction | measured | error | measured / predicted |", "|---|---|---|---|---|---|"]
    ratios = []
    for run in runs_made(out):
        scene = run.split("+")[0]
        if scene not in p:
            continue
        measured = float(read_lines(os.path.join(out, f"{run}.wall_s"))[0])
        _, done = design_run(out, run)
        ratios.append(measured / p[scene])
        rows.append(f"| `{command(run)}` | {done['iterations']} | {p[scene]:.0f} s | {measured:.1f} s | "
                    f"{100 * (p[scene] - measured) / measured:+.0f} % | {ratios[-1]:.2f} |")
    factor = math.exp(sum(math.log(r) for r in ratios) / len(ratios))
    errors = [100 * (factor - r) / r for r in ratios]
    rows += ["", f"One factor for every run (the geometric mean of measured / predicted, {factor:.2f}, applied to the whole "
             f"prediction) leaves errors from {min(errors):+.0f} % to {max(errors):+.0f} %."]
    return rows


def runs_made(out):
    """The runs this study made and finished (runs.txt, written by scripts/design_study.sh), in order."""
    return [l.strip() for l in read_lines(os.path.join(out, "runs.txt")) if l.strip()]


TABLES = {"results-table-1": table_1, "results-curves": curves, "results-roles": roles}
PERFORMANCE_TABLES = {"performance-motions": motions_cost, "performance-predicted": predicted}
DOCS = {**{name: "docs/RESULTS.md" for name in TABLES}, **{name: "docs/PERFORMANCE.md" for name in PERFORMANCE_TABLES}}
# The runs each block is made from, all of one study (runs.txt).
NEEDS = {"results-table-1": list(PAPER), "results-curves": list(PAPER), "results-roles": ROLE_RUNS,
         "performance-motions": [run for pair in MOTION_PAIRS for run in pair], "performance-predicted": list(PAPER)}


def main(argv):
    if len(argv) == 2 and argv[0] == "doc" and argv[1] in DOCS:
        print(DOCS[argv[1]])
        return 0
    if len(argv) != 2 or argv[0] not in DOCS:
        print(__doc__, file=sys.stderr)
        return 1
    block, out = argv
    try:
        absent = [run for run in NEEDS[block] if run not in runs_made(out)]
        if absent:
            raise Missing(f"not made by this study ({os.path.join(out, 'runs.txt')}): {' '.join(absent)}")
        rows = {**TABLES, **PERFORMANCE_TABLES}[block](out)
    except (Missing, ValueError, IndexError, KeyError, ZeroDivisionError) as e:
        print(f"scripts/study_tables.py: {block}: {e}", file=sys.stderr)
        return 2
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
