#!/usr/bin/env python3
"""F1 of the candidate hull against the occlusion depth (R is linear in it) and the number of
refinement passes, per shape and size: the R rule of the wide set.

  PCLX_DATA_DIR=/work/shared/data bench_hpr --wide --wide-dev --no-open3d --sizes 100000 1000000 \
      --views 2 --dev-depths 0.025 0.05 0.1 0.2 0.5 --dev-passes 0 1 2 --repeats-ours 1 \
      --csv bench/results/hpr_wide_dev_depth.csv
  /usr/bin/python3 bench/hpr/depth_chart.py docs/results/hpr/hpr.csv --out docs/results/hpr
"""
import argparse
import collections
import csv
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("csv")
    ap.add_argument("--out", default=".")
    args = ap.parse_args()
    data = collections.defaultdict(dict)
    with open(args.csv, newline="") as f:
        for rec in csv.reader(f):
            if not rec or rec[0] != "hpr":
                continue
            p = dict(kv.split("=", 1) for kv in rec[2].split(";") if "=" in kv)
            if p.get("sweep") != "wide_dev" or "depth" not in p:
                continue
            m = dict(zip(rec[6::2], rec[7::2]))
            data[(rec[3], int(rec[4]), int(p["view"]))][(float(p["depth"]), int(p["passes"]))] = float(m["f1"])
    sizes = sorted({k[1] for k in data})
    shapes = sorted({k[0] for k in data})
    fig, axes = plt.subplots(len(sizes), len(shapes), figsize=(4.2 * len(shapes), 3.6 * len(sizes)), squeeze=False)
    colours = {0: "tab:red", 1: "tab:blue", 2: "tab:green"}
    for i, n in enumerate(sizes):
        for j, shape in enumerate(shapes):
            ax = axes[i][j]
            for view, ls in ((0, "-"), (1, "--")):
                d = data.get((shape, n, view), {})
                for passes in sorted({k[1] for k in d}):
                    xs = sorted(k[0] for k in d if k[1] == passes)
                    ax.plot(xs, [d[(x, passes)] for x in xs], ls, marker="o", ms=3, color=colours.get(passes, "k"),
                            label=f"{passes} refinement pass{'es' if passes != 1 else ''}, view {view}")
            ax.axhline(0.95, color="grey", lw=1, ls=":")
            ax.axvline(0.05, color="grey", lw=1, ls="-.")
            ax.set_xscale("log")
            ax.set_ylim(0.6, 1.0)
            ax.set_title(f"{shape}, {n // 1000}k points" if n < 1000000 else f"{shape}, {n // 1000000}M points",
                         fontsize=9)
            ax.set_xlabel("occlusion depth (R is linear in it; default 0.05)", fontsize=8)
            ax.set_ylabel("F1", fontsize=8)
            ax.grid(alpha=0.3)
            if i == 0 and j == 0:
                ax.legend(fontsize=6, loc="lower left")
    fig.suptitle("Candidate hull: F1 against R (occlusion depth) and refinement passes; dotted: F1 0.95")
    fig.tight_layout()
    path = os.path.join(args.out, "hpr_wide_depth_rule.png")
    fig.savefig(path, dpi=100)
    print("wrote", path)


if __name__ == "__main__":
    main()
