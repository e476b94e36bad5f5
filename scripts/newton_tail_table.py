#!/usr/bin/env python3
"""The table of docs/PERFORMANCE.md's "Newton's tail" block from scripts/newton_tail.sh's rows.

  python3 scripts/newton_tail_table.py ROWS.jsonl
prints the block's body: per scene, Newton's iterations to grad_tol 1e-6 -> 1e-8 (ratio) fully reinforced
and all cloth, how L-BFGS to 1e-8 ended fully reinforced, then the target (at most twice the iterations
on every scene and design) met or missed. ROWS.jsonl: one object a line, {"scene", "design", "newton_1e-6",
"newton_1e-8", "lbfgs_1e-8"}, each solve `kgd simulate --json`'s object ({} for one that did not run).
Exit 2, printing nothing, when a scene lacks a design's row or a solve.
"""
import json
import sys

TARGET = 2.0


def its(r):
    return f"{r['iterations']:,}" if r.get("status") == "converged" else f"{r['iterations']:,} ({r.get('status', 'failed').replace('_', ' ')})"


def lbfgs(r):
    if r.get("status") == "converged":
        return f"{r['iterations']:,} iterations"
    if r.get("status") == "iteration_limit":
        return "iteration limit"
    return f"{r.get('status', 'failed').replace('_', ' ')} ({r.get('iterations', 0):,})"


def table(rows):
    """The body's lines; KeyError when a scene lacks a design's row or a Newton solve."""
    scenes = list(dict.fromkeys(r["scene"] for r in rows))
    by = {(r["scene"], r["design"]): r for r in rows}
    ratios, cells, lbfgs_ends = [], [], {}
    for s in scenes:
        pair = []
        for d in ("all_reinforced", "all_cloth"):
            a, b = by[(s, d)]["newton_1e-6"], by[(s, d)]["newton_1e-8"]
            converged = a.get("status") == b.get("status") == "converged"
            ratios.append(b["iterations"] / max(1, a["iterations"]) if converged else float("inf"))
            pair.append(f"{its(a)} -> {its(b)}" + (f" ({ratios[-1]:.2f})" if converged else ""))
        cells.append(f"{s.replace('_', ' ')} {pair[0]} / {pair[1]}")
        lbfgs_ends.setdefault(lbfgs(by[(s, "all_reinforced")]["lbfgs_1e-8"]), []).append(s.replace("_", " "))
    above = sum(r > TARGET for r in ratios)
    finite = [r for r in ratios if r != float("inf")]
    return [f"Newton iterations to 1e-6 -> to 1e-8 (ratio), fully reinforced / all cloth: {'; '.join(cells)}.",
            "L-BFGS to 1e-8, fully reinforced: " + "; ".join(f"{end} ({', '.join(s)})" for end, s in lbfgs_ends.items()) + ".",
            f"Target: to 1e-8 in at most {TARGET:g}x the iterations to 1e-6 on every scene and design: "
            f"{'met' if above == 0 else 'missed'}, {above} of {len(ratios)} above"
            + (f" (ratios {min(finite):.2f}-{max(finite):.2f})." if finite else ".")]


def main(argv):
    if len(argv) != 1:
        print(__doc__, file=sys.stderr)
        return 1
    try:
        with open(argv[0]) as f:
            rows = [json.loads(line) for line in f if line.strip()]
        lines = table(rows)
    except (KeyError, ValueError, OSError) as e:
        print(f"newton_tail_table.py: {argv[0]}: {type(e).__name__} {e}", file=sys.stderr)
        return 2
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
