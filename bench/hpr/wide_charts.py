#!/usr/bin/env python3
"""Charts of the wide set (bench_hpr --wide rows).

  /usr/bin/python3 bench/hpr/wide_charts.py docs/results/hpr/hpr.csv --out docs/results/hpr

hpr_wide_targets.png: per shape and size, F1 against seconds of the default (pclx_auto), the
one-pass candidate hull (the default before the refinement passes) and Open3D at its best R,
one marker per view, with the target region (F1 >= 0.95, time <= Open3D best / 50).
hpr_wide_speedup.png: Open3D-best time / our time per case, with the 50x line, and F1 of both
(with pclx_auto_t2 rows, bench_hpr --wide-lean --dev-threads 1 2: also the wall-time ratio at two threads).
"""
import argparse
import collections
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from wide_summary import read, fmt_n, TARGET_F1, TARGET_SPEEDUP  # noqa: E402

SERIES = [("pclx_auto", "ours (default, refined)", "tab:green", "o"),
          ("pclx_candidate_hull_1pass", "ours, one pass (setRefinementPasses (0))", "tab:red", "s"),
          ("open3d_exact_bestR", "Open3D exact, best R", "tab:orange", "^")]


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("csv", nargs="+")
    ap.add_argument("--out", default=".")
    ap.add_argument("--time", choices=["wall", "cpu"], default="wall", help="seconds compared (see wide_summary.py)")
    ap.add_argument("--ours", default="pclx_auto",
                    help="row of the default (pclx_auto_t1: forced to one thread, whose CPU time is comparable)")
    args = ap.parse_args()
    SERIES[0] = (args.ours,) + SERIES[0][1:]
    rows = read(args.csv, args.time)
    if not rows:
        sys.exit("wide_charts.py: no sweep=wide rows")
    groups = collections.OrderedDict()
    for r in sorted(rows, key=lambda r: (r["input"], r["points"])):
        groups.setdefault((r["input"], r["points"]), []).append(r)

    ncols = 3
    nrows = (len(groups) + ncols - 1) // ncols
    fig, axes = plt.subplots(nrows, ncols, figsize=(6 * ncols, 4.6 * nrows), squeeze=False)
    for ax in axes.flat[len(groups):]:
        ax.set_visible(False)
    for ax, ((shape, n), grows) in zip(axes.flat, groups.items()):
        views = sorted({int(r["params"].get("view", 0)) for r in grows})
        for method, text, colour, marker in SERIES:
            sel = [r for r in grows if r["method"] == method]
            ax.scatter([r["seconds"] for r in sel], [r["f1"] for r in sel], c=colour, marker=marker, s=40,
                       label=text)
            for r in sel:
                ax.annotate(f"v{r['params'].get('view', 0)}", (r["seconds"], r["f1"]), fontsize=7,
                            xytext=(3, 3), textcoords="offset points")
        for v in views:
            best = [r for r in grows if r["method"] == "open3d_exact_bestR" and int(r["params"].get("view", 0)) == v]
            if best:
                ax.axvline(best[0]["seconds"] / TARGET_SPEEDUP, color="grey", ls=":", lw=1)
        ax.axhline(TARGET_F1, color="grey", ls="--", lw=1)
        ax.set_xscale("log")
        lo = min([r["f1"] for r in grows if r["method"] in {s[0] for s in SERIES}] + [0.9])
        ax.set_ylim(max(0.0, lo - 0.02), 1.0)
        ax.set_title(f"{shape}, {fmt_n(n)} points (dotted: Open3D best / {TARGET_SPEEDUP:.0f} per view)", fontsize=9)
        ax.set_xlabel("CPU seconds" if args.time == "cpu" else "seconds")
        ax.set_ylabel("F1 vs ray-cast truth")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="lower right")
    fig.tight_layout()
    path = os.path.join(args.out, "hpr_wide_targets.png")
    fig.savefig(path, dpi=110)
    print("wrote", path)

    cases = []
    for (shape, n), grows in groups.items():
        for v in sorted({int(r["params"].get("view", 0)) for r in grows}):
            ours = [r for r in grows if r["method"] == args.ours and int(r["params"].get("view", 0)) == v]
            one = [r for r in grows if r["method"] == "pclx_candidate_hull_1pass" and int(r["params"].get("view", 0)) == v]
            best = [r for r in grows if r["method"] == "open3d_exact_bestR" and int(r["params"].get("view", 0)) == v]
            t2 = [r for r in grows if r["method"] == "pclx_auto_t2" and int(r["params"].get("view", 0)) == v]
            if ours and best:
                cases.append((f"{shape}\n{fmt_n(n)} v{v}", best[0]["seconds"] / ours[-1]["seconds"],
                              best[0]["seconds"] / one[-1]["seconds"] if one else None, ours[-1]["f1"], best[0]["f1"],
                              best[0]["wall_seconds"] / t2[-1]["wall_seconds"] if t2 else None))
    if not cases:
        return
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(max(8, 0.75 * len(cases)), 8), sharex=True)
    xs = range(len(cases))
    two = any(c[5] for c in cases)
    wd = 0.27 if two else 0.4
    a1.bar([x - wd / 2 - (wd / 2 if two else 0) for x in xs], [c[1] for c in cases], width=wd, color="tab:green",
           label="ours (default)")
    a1.bar([x + wd / 2 - (wd / 2 if two else 0) for x in xs], [c[2] or 0 for c in cases], width=wd, color="tab:red",
           label="ours, one pass")
    if two:  # wall time: two threads' CPU seconds add up, so only the wall ratio says what they gain
        a1.bar([x + wd for x in xs], [c[5] or 0 for c in cases], width=wd, color="tab:blue",
               label="ours (default), 2 threads: Open3D wall / ours wall")
    a1.axhline(TARGET_SPEEDUP, color="grey", ls="--", lw=1, label=f"{TARGET_SPEEDUP:.0f}x")
    a1.set_yscale("log")
    a1.set_ylim(top=4 * max([TARGET_SPEEDUP] + [v for c in cases for v in (c[1], c[2], c[5]) if v]))  # legend room
    a1.set_ylabel(f"Open3D best-R {'CPU ' if args.time == 'cpu' else ''}time / ours")
    a1.legend(fontsize=8)
    a1.grid(alpha=0.3, axis="y")
    a2.bar([x - 0.2 for x in xs], [c[3] for c in cases], width=0.4, color="tab:green", label="ours (default)")
    a2.bar([x + 0.2 for x in xs], [c[4] for c in cases], width=0.4, color="tab:orange", label="Open3D, best R")
    a2.axhline(TARGET_F1, color="grey", ls="--", lw=1, label=f"F1 {TARGET_F1}")
    a2.set_ylim(0.75, 1.0)
    a2.set_ylabel("F1")
    a2.legend(fontsize=8, loc="lower right")
    a2.grid(alpha=0.3, axis="y")
    a2.set_xticks(list(xs))
    a2.set_xticklabels([c[0] for c in cases], fontsize=7)
    fig.suptitle("HPR wide set: speed-up over Open3D (its best R per case) and F1")
    fig.tight_layout()
    path = os.path.join(args.out, "hpr_wide_speedup.png")
    fig.savefig(path, dpi=110)
    print("wrote", path)


if __name__ == "__main__":
    main()
