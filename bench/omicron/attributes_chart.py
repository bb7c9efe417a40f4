"""File to Potree folder against cloud size, for x y z and for scans with attributes.

Usage: attributes_chart.py ROWS.csv OUT.png RUN,RUN,...
ROWS.csv holds bench_omicron rows with a ";run=..." tag in params (omicron_read_bound.csv). One
panel per input (scene: x y z; scene_intensity: + intensity; scene_rgbi: + rgb + intensity):
ours (file to Potree folder, and the build from the file alone) beside pcl_outofcore_process and
PCL's loadPCDFile of the same file, each run a point, the line through the means.
"""
import os
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from plot import read_rows  # noqa: E402

INPUTS = [("scene", "x y z (PointXYZ)"), ("scene_intensity", "x y z intensity (PointXYZIPacked)"),
          ("scene_rgbi", "x y z rgb intensity (PointXYZRGBI)")]


def main(csv, out_png, runs):
    wanted = set(runs.split(","))
    series = defaultdict(lambda: defaultdict(lambda: defaultdict(list)))  # input -> label -> n -> [s]
    for r in read_rows([csv]):
        if r["module"] != "omicron" or r.get("p_run") not in wanted or r.get("p_sweep") != "main":
            continue
        s, n = series[r["input"]], r["points"]
        if r["method"] == "pcl_load":
            s["PCL loadPCDFile"][n].append(r["seconds"])
        elif r["method"] == "pcl_outofcore":
            s["pcl_outofcore_process -gen_lod (tmpfs ≤ 20M, disk above)"][n].append(r["seconds"])
        elif r["method"] == "omicron" and r.get("p_input") == "file":
            s["ours: build from the file"][n].append(r["seconds"])
            s["ours: file → Potree folder"][n].append(r["file_to_potree_s"])
    styles = {"ours: file → Potree folder": ("C0", "o-"), "ours: build from the file": ("C0", "s--"),
              "PCL loadPCDFile": ("C2", "^:"),
              "pcl_outofcore_process -gen_lod (tmpfs ≤ 20M, disk above)": ("C3", "D-")}
    fig, axes = plt.subplots(1, len(INPUTS), figsize=(15, 4.6), sharey=True)
    for ax, (name, title) in zip(axes, INPUTS):
        for label, (colour, style) in styles.items():
            pts = series[name].get(label)
            if not pts:
                continue
            ns = sorted(pts)
            ax.plot(ns, [sum(pts[n]) / len(pts[n]) for n in ns], style, color=colour, label=label, markersize=0)
            for n in ns:
                ax.plot([n] * len(pts[n]), pts[n], style[0], color=colour, markersize=5, alpha=0.8)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("points")
        ax.grid(True, which="both", alpha=0.3)
    axes[0].set_ylabel("seconds (2 cores, warm page cache)")
    axes[0].legend(fontsize=8, loc="upper left")
    fig.suptitle("OMiCroN: file → Potree 2.0 folder against cloud size, peers in the same runs (runs %s)" % runs)
    fig.tight_layout()
    fig.savefig(out_png, dpi=110)


if __name__ == "__main__":
    if len(sys.argv) != 4:
        sys.exit(__doc__)
    main(*sys.argv[1:])
