#!/usr/bin/env python3
"""The tables of docs/PERFORMANCE.md that Google Benchmark measures, from its JSON files.

  python3 bench/tables.py BLOCK FILE.json...

prints BLOCK's Markdown table (the body of its generated block: scripts/generated_block.py), from the
files bench/run.sh writes (--benchmark_out). Exit 2, printing nothing, when a benchmark the table
needs is absent or failed (a run with --benchmark_filter leaves the other tables as they were).
BLOCK: performance-simulator-cold, performance-simulator-warm, performance-design-engine,
performance-bodies.
"""
import json
import re
import statistics
import sys

UNIT_S = {"ns": 1e-9, "us": 1e-6, "ms": 1e-3, "s": 1.0}


class Missing(Exception):
    pass


def keep_runs(pairs):
    """A benchmark's JSON object: Google Benchmark's own "iterations" (the runs of the loop, first) as
    "loop_iterations", a counter named "iterations" (written after it) as "iterations"."""
    d = {}
    for k, v in pairs:
        d["loop_iterations" if k == "iterations" and "loop_iterations" not in d else k] = v
    return d


def load(paths):
    """Benchmark name (without /iterations:N, /real_time) -> list of its runs (dicts)."""
    runs = {}
    for p in paths:
        try:
            with open(p) as f:
                data = json.load(f, object_pairs_hook=keep_runs)
        except ValueError as e:  # a benchmark program that died wrote half a file
            print(f"bench/tables.py: {p}: {e}", file=sys.stderr)
            continue
        for b in data.get("benchmarks", []):
            if b.get("run_type", "iteration") != "iteration" or b.get("error_occurred"):
                continue
            name = re.sub(r"/(iterations:\d+|real_time|manual_time)", "", b["name"])
            runs.setdefault(name, []).append(b)
    return runs


class Results:
    def __init__(self, runs):
        self.runs = runs

    def get(self, name, key):
        """Median over repetitions of a counter, or of the real time in seconds (key 'seconds')."""
        if name not in self.runs:
            raise Missing(name)
        values = []
        for b in self.runs[name]:
            if key == "seconds":
                values.append(b["real_time"] * UNIT_S[b.get("time_unit", "ns")])
            elif key in b:
                values.append(b[key])
            else:
                raise Missing(f"{name}: {key}")
        return statistics.median(values)


def thousands(v):
    return f"{round(v):,}"


def times(v):
    return f"{v:.0f}x" if v >= 10 else f"{v:.1f}x"


def simulator_cold(r):
    rows = ["| design | tol | Newton | L-BFGS | Newton / L-BFGS |", "|---|---|---|---|---|"]
    for tol in (4, 6):
        for reinforced, design in ((0, "cloth"), (1, "reinforced")):
            n = f"BM_NewtonCold/reinforced:{reinforced}/tol_exp:{tol}/project:1"
            l = f"BM_LbfgsCold/reinforced:{reinforced}/tol_exp:{tol}"
            tn, tl = r.get(n, "seconds"), r.get(l, "seconds")
            rows.append(f"| {design} | 1e-{tol} | {tn:.2f} s, {thousands(r.get(n, 'iterations'))} iterations, "
                        f"E = {r.get(n, 'energy_J'):.6g} J | {tl:.2f} s, {thousands(r.get(l, 'iterations'))} iterations, "
                        f"E = {r.get(l, 'energy_J'):.6g} J | {times(tl / tn)} |")
    return rows


def simulator_warm(r):
    rows = ["| flips | method | per re-solve | Newton iterations / factorizations / local steps |", "|---|---|---|---|"]
    for name, flips, bench in (("BM_WarmResolve/method:{}/tol_exp:4", "random faces", "`BM_WarmResolve`"),
                               ("BM_WarmResolveBeso/method:{}", "the faces BESO flips", "`BM_WarmResolveBeso`")):
        n, l = name.format(1), name.format(2)
        steps = f"{round(r.get(n, 'loop_iterations'))} steps"
        rows.append(f"| {flips}, {steps} ({bench}) | Newton | {1e3 * r.get(n, 'seconds'):.0f} ms | {r.get(n, 'iterations'):.1f} / "
                    f"{r.get(n, 'factorizations'):.2f} / {r.get(n, 'local_steps'):.2f} |")
        rows.append(f"| {flips} | L-BFGS | {1e3 * r.get(l, 'seconds'):.0f} ms | "
                    f"{r.get(l, 'iterations'):.0f} L-BFGS iterations |")
    return rows


def design_engine(r):
    rows = ["| run | vertices | first iteration | per iteration | Newton its per iteration | simulation | "
            "sensitivities / filter / update / HDF5 | density ratio at the end |", "|---|---|---|---|---|---|---|---|"]
    runs = (("BM_ArmFlexion20", "arm flexion, iterations 0-{last}", False),
            ("BM_ArmFlexionRun", "arm flexion, the whole run ({n} iterations)", True),
            ("BM_Slouch10", "slouch, iterations 0-{last}", False),
            ("BM_SlouchPaperResolutionRun", "slouch at the paper's size (`--body resolution_m=0.010`), the whole run "
                                            "({n} iterations; `BM_SlouchPaperResolutionRun`)", True))
    for name, label, whole in runs:
        g = lambda key: r.get(name, key)
        n = round(g("iterations"))
        ratio = f"{g('density_ratio'):.3f}" + (f" ({g('run_s'):.1f} s in all)" if whole else "")
        rows.append(f"| {label.format(n=n, last=n - 1)} | {thousands(g('vertices'))} | {g('first_s'):.2f} s | "
                    f"{g('per_iter_s'):.3f} s | {g('newton_per_iter'):.1f} | {g('sim_s'):.3f} s | "
                    f"{g('sens_ms'):.2f} / {g('filter_ms'):.2f} / {g('update_ms'):.2f} / {g('hdf5_ms'):.1f} ms | {ratio} |")
    return rows


def bodies(r):
    s = lambda name: f"{r.get(name, 'seconds'):.3g}"
    v = lambda name: thousands(r.get(name, "vertices"))
    scenes = ", ".join(s(f"BM_PaperScene/{i}") for i in range(7))
    return [
        "| what | time |", "|---|---|",
        f"| build the parametric body at 13 mm (default; {v('BM_BuildParametricBody/13')} vertices) / at 8 mm "
        f"({v('BM_BuildParametricBody/8')}) | {s('BM_BuildParametricBody/13')} s / {s('BM_BuildParametricBody/8')} s |",
        f"| pose it: elbow 15 -> 100 degrees / the crouch | {s('BM_PoseBody/0')} s / {s('BM_PoseBody/5')} s |",
        "| a built-in scene from the built body (every frame posed, garment cut): arm flexion, arm extension, knee "
        f"flexion, knee extension, slouch, crouch, lunge | {scenes} s |",
        f"| arm flexion fully reinforced through its frames ({v('BM_SimulateFrames/0')} vertices, "
        f"{thousands(r.get('BM_SimulateFrames/0', 'newton_its'))} Newton iterations) / knee flexion "
        f"({v('BM_SimulateFrames/2')}, {thousands(r.get('BM_SimulateFrames/2', 'newton_its'))}) | "
        f"{s('BM_SimulateFrames/0')} s / {s('BM_SimulateFrames/2')} s |",
    ]


TABLES = {
    "performance-simulator-cold": simulator_cold,
    "performance-simulator-warm": simulator_warm,
    "performance-design-engine": design_engine,
    "performance-bodies": bodies,
}


def main(argv):
    if len(argv) < 2 or argv[0] not in TABLES:
        print(__doc__, file=sys.stderr)
        return 1
    try:
        rows = TABLES[argv[0]](Results(load(argv[1:])))
    except Missing as e:
        print(f"bench/tables.py: {argv[0]}: no result for {e}", file=sys.stderr)
        return 2
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
