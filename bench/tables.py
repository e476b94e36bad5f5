#!/usr/bin/env python3
"""The tables `make bench` measures, from the files bench/run.sh writes in BUILD/bench-results.

  python3 bench/tables.py BLOCK FILE.json...
      prints BLOCK's body (a Markdown table and its lines: scripts/generated_block.py) from the files:
      Google Benchmark's (--benchmark_out) and the other benchmarks' JSON objects, told apart by their
      "kind" (service, web, export, pinned, effects, scale). Exit 2, printing nothing, when a result the
      block needs is absent or failed (a run with --benchmark_filter leaves the other blocks as they were).
  python3 bench/tables.py write RESULTS_DIR --machine "$(kgd machine)" [--docs DOCS_DIR]
      writes every block of BLOCKS whose results are all in RESULTS_DIR/*.json into its page of DOCS_DIR
      (default: the source's docs/), headed by the command that measured it (RESULTS_DIR/commands.tsv:
      kind TAB command, as bench/run.sh records them) and the machine; exit 2 when a block was not written.
"""
import argparse
import glob
import importlib.util
import json
import os
import re
import statistics
import sys

UNIT_S = {"ns": 1e-9, "us": 1e-6, "ms": 1e-3, "s": 1.0}
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


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
    """(Google Benchmark name without /iterations:N, /real_time -> list of its runs; kind -> object), the
    kind of a scale run being "scale:SCENE"."""
    runs, kinds = {}, {}
    for p in paths:
        try:
            with open(p) as f:
                text = f.read()
            data = json.loads(text)
            if "kind" not in data:
                data = json.loads(text, object_pairs_hook=keep_runs)
        except (ValueError, OSError) as e:  # a benchmark program that died wrote half a file
            print(f"bench/tables.py: {p}: {e}", file=sys.stderr)
            continue
        if "kind" in data:
            kinds[data["kind"] + (":" + data["scene"] if data["kind"] == "scale" else "")] = data
            continue
        for b in data.get("benchmarks", []):
            if b.get("run_type", "iteration") != "iteration" or b.get("error_occurred"):
                continue
            name = re.sub(r"/(iterations:\d+|real_time|manual_time)", "", b["name"])
            runs.setdefault(name, []).append(b)
    return runs, kinds


class Results:
    def __init__(self, loaded):
        self.runs, self.kinds = loaded

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

    def kind(self, kind):
        """The JSON object of one benchmark program (service, web, export, pinned, effects, scale:SCENE)."""
        if kind not in self.kinds:
            raise Missing(f"the {kind} benchmark's results")
        return self.kinds[kind]


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
    e6 = r.get("BM_NewtonCold/reinforced:0/tol_exp:6/project:1", "energy_J")
    above = lambda name: 100 * (r.get(name, "energy_J") - e6) / e6
    rows += ["", f"At 1e-4 on the cloth sleeve, Newton stops {above('BM_NewtonCold/reinforced:0/tol_exp:4/project:1'):.3g} % above "
                 f"Newton's energy at 1e-6, L-BFGS {above('BM_LbfgsCold/reinforced:0/tol_exp:4'):.3g} %: equal tolerances are "
                 "unequal accuracies."]
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
    return rows + [""] + simulator_parts(r)


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
    a = "BM_DesignFileAppend"
    rows += ["", f"Appending one arm-flexion-sized iteration (7,056 vertices, 13,690 faces) to a design file (`{a}`): "
                 f"{1e3 * r.get(a, 'seconds'):.1f} ms each over {round(r.get(a, 'iterations'))} appends; the file then holds "
                 f"{r.get(a, 'file_MB'):.0f} MB."]
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



def simulator_parts(r):
    ms = lambda name: f"{1e3 * r.get(name, 'seconds'):.3g}"
    cold = "BM_NewtonCold/reinforced:1/tol_exp:4/project:1"
    parts = " / ".join(f"{r.get(cold, k) / 1e3:.2f}" for k in ("factor_ms", "assembly_ms", "linesearch_ms", "solve_ms"))
    return [
        "| what a Newton iteration is made of | time |", "|---|---|",
        "| one evaluation at the reinforced sleeve's equilibrium (`BM_Evaluate`): energy only / with gradient / with gradient "
        f"and Hessian / the body field alone | {ms('BM_Evaluate/what:0')} / {ms('BM_Evaluate/what:1')} / {ms('BM_Evaluate/what:2')} / "
        f"{ms('BM_Evaluate/what:3')} ms |",
        f"| one factorization (`BM_Factorize`, {r.get('BM_Factorize/split:0', 'factor_nnz') / 1e6:.2f} M factor entries): in one "
        f"piece / as two domains on two threads | {ms('BM_Factorize/split:0')} / {ms('BM_Factorize/split:1')} ms |",
        f"| the cold reinforced solve to 1e-4 ({r.get(cold, 'seconds'):.2f} s): factorization / assembly / line search / "
        f"back-substitution | {parts} s |",
    ]


def solver_options(r):
    def cold(reinforced, project):
        n = f"BM_NewtonCold/reinforced:{reinforced}/tol_exp:6/project:{project}"
        return (f"{r.get(n, 'seconds'):.2f} s, {round(r.get(n, 'iterations'))} iterations"
                + ("" if r.get(n, "converged") else ", not converged"))

    def warm(name, pcg=False):
        return (f"{1e3 * r.get(name, 'seconds'):.0f} ms, {r.get(name, 'factorizations'):.2f} factorizations"
                + (f", {r.get(name, 'pcg_iterations'):.2f} PCG iterations" if pcg else ""))

    w = "BM_WarmResolve/method:{}/tol_exp:4"
    s = "BM_WarmResolveSmooth/method:{}"
    f = lambda split: f"{1e3 * r.get(f'BM_Factorize/split:{split}', 'seconds'):.3g} ms"
    return [
        "| option (default) | with | without |", "|---|---|---|",
        f"| `local_steps` (on): steps on the region that holds the residual | warm re-solve {warm(w.format(1))} | {warm(w.format(4))} |",
        "| `project_contact_crossings` (on): vertices a trial step carries into the body put back on its surface | cold to 1e-6: "
        f"cloth {cold(0, 1)}; reinforced {cold(1, 1)}; warm re-solve {1e3 * r.get(w.format(1), 'seconds'):.0f} ms | cloth {cold(0, 0)}; "
        f"reinforced {cold(1, 0)}; warm re-solve {1e3 * r.get(w.format(3), 'seconds'):.0f} ms |",
        f"| `reuse_factorization` (off): PCG on this solve's factorization | relaxed sleeve, warm: {warm(w.format(0), True)}; smooth model "
        f"(no relaxation, bilateral contact), warm: {warm(s.format(0), True)} | relaxed: {warm(w.format(1))}; smooth: {warm(s.format(1))} |",
        f"| two domains on two threads (above 9,000 unknowns) | factorization {f(1)} | {f(0)} |",
    ]


def service(r):
    d = r.kind("service")
    lat = sorted((l for l in d["latency"] if not l["pinned"]), key=lambda l: l["watchers"])
    if len(lat) < 2 or "overhead" not in d:
        raise Missing("the service benchmark's latency with 1 and W watchers and its overhead")
    if any(l["worker_s_per_iteration"] <= 0 for l in lat):
        raise Missing("the worker's time per iteration of every latency run (a run whose watcher saw no iteration)")
    one, many = lat[0], lat[-1]
    rows = [f"| watchers (`{one['scene']}`, {one['iterations']} iterations) | p50 | p99 | server CPU per iteration | worker s per iteration |", "|---|---|---|---|---|"]
    for l in lat:
        rows.append(f"| {l['watchers']} | {l['p50_ms']:.1f} ms | {l['p99_ms']:.1f} ms | {l['server_cpu_ms_per_iteration']:.1f} ms | "
                    f"{l['worker_s_per_iteration']:.3f} |")
    per_watcher = (many["server_cpu_ms_per_iteration"] - one["server_cpu_ms_per_iteration"]) / max(1, many["watchers"] - one["watchers"])
    worker = 100 * (many["worker_s_per_iteration"] / one["worker_s_per_iteration"] - 1)
    o = d["overhead"]
    rows += ["", f"{many['watchers']} watchers cost the worker {worker:+.0f} % per iteration (their threads share its cores) and the server "
                 f"{per_watcher:.2f} ms of CPU per iteration each. `{o['scene']}`, {o['iterations']} iterations, best of {o['repeat']}: "
                 f"`kgd design` locally {o['local_s']:.2f} s, through server and worker {o['service_s']:.2f} s to the last iteration's record "
                 f"({100 * (o['service_s'] / o['local_s'] - 1):+.0f} %)."]
    return rows


def web(r):
    d = r.kind("web")
    e, p, v = d["sse"], d["page"], d["view"]
    return [
        "| measure | how | today |", "|---|---|---|",
        f"| worker report to Server-Sent Event | an arm-flexion job of {e['iterations']} iterations watched by {e['watchers']} "
        f"`:watch?view=metrics` streams at once ({e['complete']} saw every iteration, {e['failed']} refused or failed); arrival time minus the "
        f"iteration's `reportTimeS`, over {e['events']:,} events | p50 {e['p50_ms']:.1f} ms, p99 {e['p99_ms']:.1f} ms |",
        "| page ready | headless Chromium (Debian's, software WebGL) from navigation to the scene list and the jobs list shown, "
        f"median of {p['pages']} fresh pages | {p['median_ms']:.0f} ms (slowest {p['max_ms']:.0f} ms) |",
        f"| a {v['vertices']:,}-vertex iteration applied to the 3D view | a 140 x 200 tube ({v['faces']:,} faces): positions and design "
        f"colours written into the view's buffers and drawn, to `gl.finish()`, median of {v['draws']} | {v['median_ms']:.1f} ms "
        f"(slowest {v['max_ms']:.1f} ms) |",
    ]


def export(r):
    d = r.kind("export")
    rows = ["| design | export, median (fastest) | of which (medians) |", "|---|---|---|"]
    for x in d["designs"]:
        stages = ", ".join(f"{stage} {s:.2f} s" for stage, s in x["stage_median_s"].items())
        rows.append(f"| {x['scene'].replace('_', ' ')}, {x['faces']:,} faces, iteration {x['iteration']} | {x['median_s']:.2f} s "
                    f"({x['fastest_s']:.2f} s) over {x['runs']} runs | {stages}; the pattern, cut alongside, "
                    f"{x['pattern_median_s']:.2f} s |")
    return rows


def pinned(r):
    d = r.kind("pinned")
    a = d["native"]
    part = lambda b, what, key, fmt: f"{what} {b[key]:{fmt}} s against {a[key]:{fmt}} s ({100 * (b[key] / a[key] - 1):+.0f} %)"
    # The highest level is the one kgd chooses on the machine.
    levels = list(d["levels"].items())[::-1]
    return ["`kgd design arm_flexion` at each kernel level this machine runs, against its own kernels (`KGD_NATIVE_KERNELS=1`): "
            + "; ".join(f"{level}{' (the default here)' if k == 0 else ''}: "
                        + ", ".join((part(b, "iteration 0 (cold solve, fully reinforced)", "first_s", ".2f"),
                                     part(b, f"the mean of iterations 1-{b['iterations']}", "mean_later_s", ".3f"),
                                     part(b, f"the whole loop of {b['iterations'] + 1} iterations", "loop_s", ".1f")))
                        for k, (level, b) in enumerate(levels)) + "."]


EFFECTS = {
    "as_built": "as built in (membrane, exact relaxation, unilateral contact, attachments, fold barrier)",
    "no_fold_barrier": "without the fold barrier (the paper's model exactly)",
    "friction": "with friction mu = 0.1 (lagged passes)",
    "bilateral_contact": "bilateral contact",
    "authors_relaxation": "the authors' relaxation (C0)",
    "no_relaxation": "no relaxation (compression resisted)",
    "no_contact": "without contact (no body field built; the garment keeps the facets' shape)",
    "no_attachments": "without attachments",
}


def effects(r):
    d = r.kind("effects")
    got = {v["variant"]: v for v in d["variants"]}
    rows = ["| arm flexion, fully reinforced | solve | solver iterations (with local steps) | energy |", "|---|---|---|---|"]
    for name, label in EFFECTS.items():
        if name not in got:
            raise Missing(f"effects: {name}")
        v = got[name]
        rows.append(f"| {label} | {v['seconds']:.2f} s | {v['iterations']}{'' if v['status'] == 'converged' else ' (' + v['status'].replace('_', ' ') + ')'} | "
                    f"{v['energy_J']:.6f} J |")
    return rows


def verdict(ok):
    return "met" if ok else "missed"


def targets(r):
    arm, arm20, slouch = "BM_ArmFlexionRun", "BM_ArmFlexion20", "BM_SlouchPaperResolutionRun"
    cold = {(d, t): (r.get(f"BM_NewtonCold/reinforced:{d}/tol_exp:{t}/project:1", "seconds"), r.get(f"BM_LbfgsCold/reinforced:{d}/tol_exp:{t}", "seconds"))
            for d in (0, 1) for t in (4, 6)}
    warm = {k: (r.get(n.format(1), "seconds"), r.get(n.format(2), "seconds"))
            for k, n in (("random", "BM_WarmResolve/method:{}/tol_exp:4"), ("beso", "BM_WarmResolveBeso/method:{}"))}
    ratios = [l / n for n, l in list(cold.values()) + list(warm.values())]
    svc = sorted((l for l in r.kind("service")["latency"] if not l["pinned"]), key=lambda l: l["watchers"])
    if len(svc) < 2:
        raise Missing("the service benchmark's latency with 1 and W watchers")
    w = r.kind("web")
    x = {d["scene"]: d for d in r.kind("export")["designs"]}
    if "arm_flexion" not in x:
        raise Missing("the arm's export")
    per_it, per_it20, slouch_it = r.get(arm, "per_iter_s"), r.get(arm20, "per_iter_s"), r.get(slouch, "per_iter_s")
    lat = "; ".join(f"{l['p50_ms']:.1f} ms / {l['p99_ms']:.1f} ms with {l['watchers']}" for l in svc)
    return [
        "| target | today | |", "|---|---|---|",
        f"| a design iteration of arm flexion ({thousands(r.get(arm, 'vertices'))} vertices) well under 0.1 s; the paper: 10.65 s on a GPU | "
        f"{per_it:.3f} s per iteration over the whole run ({round(r.get(arm, 'iterations'))} iterations, {r.get(arm, 'run_s'):.1f} s), "
        f"{per_it20:.3f} s over its first 20 | {verdict(per_it < 0.1)} |",
        f"| a slouch iteration at the paper's size ({thousands(r.get(slouch, 'vertices'))} vertices) under 0.5 s; the paper: 15.8 s | "
        f"{slouch_it:.3f} s per iteration, {round(r.get(slouch, 'iterations'))} iterations in {r.get(slouch, 'run_s'):.1f} s | "
        f"{verdict(slouch_it < 0.5)} |",
        f"| cold solve of the 7k benchmark sleeve under 0.5 s | {cold[(0, 4)][0]:.2f} s cloth, {cold[(1, 4)][0]:.2f} s reinforced "
        f"(tolerance 1e-4) | {verdict(max(cold[(0, 4)][0], cold[(1, 4)][0]) < 0.5)} |",
        f"| warm re-solve after a 1.5 % design change under 50 ms | {1e3 * warm['random'][0]:.0f} ms (random faces), "
        f"{1e3 * warm['beso'][0]:.0f} ms (the faces BESO flips) | {verdict(max(warm['random'][0], warm['beso'][0]) < 0.05)} |",
        f"| Newton 20x faster than L-BFGS to the same tolerance | cold: {times(cold[(0, 4)][1] / cold[(0, 4)][0])} (cloth) / "
        f"{times(cold[(1, 4)][1] / cold[(1, 4)][0])} (reinforced) at 1e-4, {times(cold[(0, 6)][1] / cold[(0, 6)][0])} / "
        f"{times(cold[(1, 6)][1] / cold[(1, 6)][0])} at 1e-6; warm: {times(warm['random'][1] / warm['random'][0])} on random flips, "
        f"{times(warm['beso'][1] / warm['beso'][0])} on BESO's | {verdict(min(ratios) >= 20)} |",
        f"| fabrication export of the arm design <= 1 s | {x['arm_flexion']['median_s']:.2f} s (median of {x['arm_flexion']['runs']}) "
        f"with the PNG previews | {verdict(x['arm_flexion']['median_s'] <= 1)} |",
        f"| report to watcher p50 <= 20 ms, p99 <= 50 ms | {lat} | "
        + ", ".join(f"{verdict(l['p50_ms'] <= 20 and l['p99_ms'] <= 50)} with {l['watchers']}" for l in svc) + " |",
        f"| worker report to Server-Sent Event p99 <= 50 ms with 100 SSE watchers | {w['sse']['p99_ms']:.1f} ms with "
        f"{w['sse']['watchers']} (p50 {w['sse']['p50_ms']:.1f} ms) | {verdict(w['sse']['p99_ms'] <= 50 and w['sse']['watchers'] >= 100)} |",
        f"| web page ready on loopback <= 1 s | {w['page']['median_ms'] / 1e3:.2f} s | {verdict(w['page']['median_ms'] <= 1000)} |",
        f"| a 28k-vertex iteration applied to the 3D view <= 50 ms | {w['view']['median_ms']:.1f} ms (median; slowest of "
        f"{w['view']['draws']} {w['view']['max_ms']:.1f} ms) | {verdict(w['view']['median_ms'] <= 50)} |",
    ]


def scale_table(d, arm):
    if not d["runs"]:
        raise Missing(f"scale:{d['scene']}: no runs")
    rows = [f"{d['jobs']} jobs of `{d['scene']}`, up to {d['iterations']} iterations each, `OMP_NUM_THREADS={d['threads']}` per worker, "
            f"{d['cores']} cores:", ""]
    if arm:
        rows += ["| workers | iterations/s | server CPU per iteration | SQLite per commit | HDF5 per iteration |", "|---|---|---|---|---|"]
    else:
        rows += ["| workers | jobs/min | iterations/s | server CPU per iteration | SQLite commits/s | SQLite per commit | HDF5 per iteration |",
                 "|---|---|---|---|---|---|---|"]
    for x in d["runs"]:
        failed = "" if x["succeeded"] == x["jobs"] else f" ({x['succeeded']} of {x['jobs']} succeeded)"
        if arm:
            rows.append(f"| {x['workers']} | {x['iterations_per_s']:.1f} | {x['server_cpu_ms_per_iteration']:.2f} ms | "
                        f"{x['sqlite_ms_per_commit']:.2f} ms | {x['hdf5_ms_per_iteration']:.2f} ms{failed} |")
        else:
            rows.append(f"| {x['workers']} | {x['jobs_per_min']:.1f} | {x['iterations_per_s']:.1f} | {x['server_cpu_ms_per_iteration']:.2f} ms | "
                        f"{x['commits_per_s']:.1f} | {x['sqlite_ms_per_commit']:.2f} ms | {x['hdf5_ms_per_iteration']:.2f} ms{failed} |")
    return rows


def scaling_sleeve(r):
    return scale_table(r.kind("scale:sleeve_on_limb"), arm=False)


def scaling_arm(r):
    return scale_table(r.kind("scale:arm_flexion"), arm=True)


def scaling_sustain(r):
    d = r.kind("scale:arm_flexion")
    s = d.get("sustain")
    if not s:
        raise Missing("scale:arm_flexion: the one-worker run's sustain figure")
    return [f"One worker (`OMP_NUM_THREADS={d['threads']}`, kernels pinned as `kgd-worker` runs) takes {s['worker_s_per_iteration']:.3f} s "
            f"per arm-flexion iteration after each job's first ({s['worker_iterations_per_s']:.1f} per second), and each costs the server "
            f"{s['server_cpu_ms_per_iteration']:.2f} ms of CPU: one server core sustains about {s['workers_per_server_core']:.{0 if s['workers_per_server_core'] >= 10 else 1}f} such "
            f"workers without watchers. The store's writer lock (one HDF5 append and one SQLite commit per iteration, "
            f"{s['store_ms_per_iteration']:.2f} ms) lets at most {s['store_iterations_per_s']:.0f} iterations per second through."]


PERFORMANCE, SCALING = "PERFORMANCE.md", "SCALING.md"
# block -> (renderer, page in docs/, the results it reads: bench/run.sh's kinds).
BLOCKS = {
    "performance-targets": (targets, PERFORMANCE, ("simulate", "design", "service", "web", "export")),
    "performance-simulator-cold": (simulator_cold, PERFORMANCE, ("simulate",)),
    "performance-simulator-warm": (simulator_warm, PERFORMANCE, ("simulate",)),
    "performance-design-engine": (design_engine, PERFORMANCE, ("design",)),
    "performance-bodies": (bodies, PERFORMANCE, ("body",)),
    "performance-service": (service, PERFORMANCE, ("service",)),
    "performance-web": (web, PERFORMANCE, ("web",)),
    "performance-export": (export, PERFORMANCE, ("export",)),
    "performance-pinned": (pinned, PERFORMANCE, ("pinned",)),
    "performance-solver-options": (solver_options, PERFORMANCE, ("simulate",)),
    "performance-effects": (effects, PERFORMANCE, ("effects",)),
    "scaling-sleeve": (scaling_sleeve, SCALING, ("scale:sleeve_on_limb",)),
    "scaling-arm": (scaling_arm, SCALING, ("scale:arm_flexion",)),
    "scaling-sustain": (scaling_sustain, SCALING, ("scale:arm_flexion",)),
}
TABLES = {name: b[0] for name, b in BLOCKS.items()}


def render(block, results):
    """BLOCK's lines; Missing when a result it needs is absent."""
    try:
        return BLOCKS[block][0](results)
    except (KeyError, TypeError, ZeroDivisionError) as e:  # a result file of another shape
        raise Missing(f"{type(e).__name__} {e}")


def commands(results_dir):
    """kind -> the command that measured it (RESULTS_DIR/commands.tsv, written by bench/run.sh)."""
    out = {}
    try:
        with open(os.path.join(results_dir, "commands.tsv")) as f:
            for line in f:
                kind, _, cmd = line.rstrip("\n").partition("\t")
                out[kind] = cmd
    except OSError:
        pass
    return out


def generated_block():
    spec = importlib.util.spec_from_file_location("generated_block", os.path.join(ROOT, "scripts", "generated_block.py"))
    m = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(m)
    return m


def write(results_dir, docs, machine):
    """Every block whose results are all in RESULTS_DIR into its page; the number of blocks not written."""
    gb = generated_block()
    results = Results(load(sorted(glob.glob(os.path.join(results_dir, "*.json")))))
    cmds = commands(results_dir)
    not_written = 0
    for block, (_, page, sources) in BLOCKS.items():
        path = os.path.join(docs, page)
        try:
            body = "\n".join(render(block, results))
        except Missing as e:
            print(f"{path}: {block} not written (no result for {e})", file=sys.stderr)
            not_written += 1
            continue
        command = cmds.get(sources[0], "make bench") if len(sources) == 1 else "make bench"
        try:
            with open(path) as f:
                text = f.read()
            gb.write_atomically(path, gb.replace(text, block, body, command, machine.strip()))
        except (gb.MarkerError, OSError) as e:
            print(f"{path}: {block} not written ({e})", file=sys.stderr)
            not_written += 1
            continue
        print(f"{path}: {block} written")
    return not_written


def main(argv):
    if argv[:1] == ["write"]:
        p = argparse.ArgumentParser(prog="tables.py write")
        p.add_argument("results")
        p.add_argument("--machine", required=True)
        p.add_argument("--docs", default=os.path.join(ROOT, "docs"))
        a = p.parse_args(argv[1:])
        return 2 if write(a.results, a.docs, a.machine) else 0
    if len(argv) < 2 or argv[0] not in BLOCKS:
        print(__doc__, file=sys.stderr)
        return 1
    try:
        rows = render(argv[0], Results(load(argv[1:])))
    except Missing as e:
        print(f"bench/tables.py: {argv[0]}: no result for {e}", file=sys.stderr)
        return 2
    print("\n".join(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
