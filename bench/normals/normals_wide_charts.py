#!/usr/bin/env python3
"""Charts of `bench_normals --wide` rows.

  /usr/bin/python3 bench/normals/normals_wide_charts.py docs/results/normals/normals.csv \
      --out docs/results/normals

normals_wide_rms_vs_noise.png   per shape: RMS against σ for ours, oracle PCA (k written beside it),
                                PCA k = 18, jet best, VCM best, Open3D k = 18 / hybrid
normals_wide_error_vs_time.png  per shape and σ: RMS against seconds of every run (the k / radius
                                sweeps as lines), ours as a star
normals_wide_delta.png          per shape and σ: ours − oracle PCA (bars) with the issue's +0.5° bar,
                                jet best − oracle and VCM best − oracle as markers
normals_wide_speed.png          speed sweep: seconds and RMS against points, ours vs PCL k = 18
"""
import argparse
import collections
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from normals_wide_summary import read  # noqa: E402  (one CSV reader for both scripts)

SIGMAS = [0.0, 0.0012, 0.006, 0.012]
MAIN = [("ours", "ours (default)", "tab:red", "*"),
        ("oracle_pca", "oracle PCA (best k)", "tab:blue", "o"),
        ("pca_k18", "PCA k = 18", "tab:cyan", "v"),
        ("jet_best", "CGAL jet, best k", "tab:green", "s"),
        ("vcm_best", "CGAL VCM, best radii", "tab:orange", "D"),
        ("open3d_k18", "Open3D k = 18", "tab:gray", "x"),
        ("open3d_hybrid", "Open3D hybrid", "tab:olive", "+")]


def shapes_of(rows):
    seen = []
    for r in rows:
        if r["input"] not in seen:
            seen.append(r["input"])
    return seen


def rms_vs_noise(rows, out):
    wide = [r for r in rows if r.get("p_sweep") == "wide" and "rms" in r]
    shapes = shapes_of(wide)
    if not shapes:
        return None
    ncols = min(4, len(shapes))
    nrows = (len(shapes) + ncols - 1) // ncols
    fig, axes = plt.subplots(nrows, ncols, figsize=(4.6 * ncols, 3.9 * nrows), squeeze=False)
    for ax in axes.flat[len(shapes):]:
        ax.set_visible(False)
    for ax, shape in zip(axes.flat, shapes):
        srows = [r for r in wide if r["input"] == shape]
        sig = sorted({float(r["p_noise"]) for r in srows})
        xs = {s: i for i, s in enumerate(sig)}
        for mi, (method, lab, color, marker) in enumerate(MAIN):
            # A small horizontal offset per method keeps coinciding points (oracle PCA and jet) visible.
            dx = 0.035 * (mi - len(MAIN) / 2)
            pts = sorted(((xs[float(r["p_noise"])] + dx, r["rms"], id(r)), r) for r in srows if r["method"] == method)
            pts = [(x, y, r) for (x, y, _), r in pts]
            if not pts:
                continue
            ax.plot([p[0] for p in pts], [p[1] for p in pts], marker=marker, color=color, label=lab,
                    linewidth=2.2 if method == "ours" else 1.2, markersize=9 if method == "ours" else 5)
            if method == "oracle_pca":
                for x, y, r in pts:
                    ax.annotate("k=" + r.get("p_k", "?"), (x, y), textcoords="offset points", xytext=(4, -10),
                                fontsize=7, color=color)
        ax.set_xticks(range(len(sig)))
        ax.set_xticklabels([f"{s:g}" for s in sig])
        ax.set_xlabel("noise σ / bbox diagonal")
        ax.set_ylabel("RMS angle error (deg)")
        ax.set_title(shape, fontsize=10)
        ax.grid(True, alpha=0.3)
    axes.flat[0].legend(fontsize=7)
    fig.suptitle("Normals, wide set: RMS error against noise, 100k points, 2 threads", fontsize=11)
    fig.tight_layout()
    path = os.path.join(out, "normals_wide_rms_vs_noise.png")
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def delta(rows, out):
    wide = [r for r in rows if r.get("p_sweep") == "wide" and "rms" in r]
    shapes = shapes_of(wide)
    if not shapes:
        return None
    sig = sorted({float(r["p_noise"]) for r in wide})
    best = {(r["input"], float(r["p_noise"]), r["method"]): r["rms"] for r in wide}
    fig, ax = plt.subplots(figsize=(max(8, 1.6 * len(shapes)), 4.8))
    width = 0.8 / len(sig)
    colors = ["#4c72b0", "#55a868", "#c44e52", "#8172b2"]
    for j, s in enumerate(sig):
        xs, hs = [], []
        for i, shape in enumerate(shapes):
            o, q = best.get((shape, s, "ours")), best.get((shape, s, "oracle_pca"))
            if o is None or q is None:
                continue
            x = i - 0.4 + width * (j + 0.5)
            xs.append(x)
            hs.append(o - q)
            for peer, marker in (("jet_best", "s"), ("vcm_best", "D")):
                p = best.get((shape, s, peer))
                if p is not None:
                    ax.scatter([x], [p - q], marker=marker, color="k", s=14, zorder=5,
                               label={"jet_best": "jet best − oracle", "vcm_best": "VCM best − oracle"}[peer]
                               if (i, j) == (0, 0) else None)
        bars = ax.bar(xs, hs, width=width, color=colors[j % len(colors)], label=f"ours − oracle, σ = {s:g}")
        ax.bar_label(bars, fmt="%+.2f", fontsize=6, rotation=90, padding=2)
    ax.axhline(0.5, color="r", linestyle="--", linewidth=1)
    ax.annotate("bar: +0.5°", (0.005, 0.5), xycoords=("axes fraction", "data"), fontsize=8, color="r", va="bottom")
    ax.axhline(0, color="k", linewidth=0.6)
    ax.set_xticks(range(len(shapes)))
    ax.set_xticklabels(shapes)
    ax.set_ylabel("RMS difference to oracle PCA (deg)")
    lo = min([0] + [b - best.get((a, c, "oracle_pca"), b) for (a, c, m), b in best.items() if m == "ours"])
    ax.set_ylim(max(lo - 0.5, -3), None)  # the clean cube's -6° would flatten the rest
    ax.grid(True, axis="y", alpha=0.3)
    ax.legend(fontsize=7, ncol=3)
    ax.set_title("Normals, wide set: ours − oracle PCA per shape and noise (lower is better; clipped at −3°)", fontsize=10)
    fig.tight_layout()
    path = os.path.join(out, "normals_wide_delta.png")
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def family(method):
    for f in ("pca_k", "jet_k", "vcm_R"):
        if method.startswith(f):
            return f
    return method


def error_vs_time(rows, out):
    wide = [r for r in rows if r.get("p_sweep") == "wide" and "rms" in r]
    shapes = shapes_of(wide)
    if not shapes:
        return None
    sig = sorted({float(r["p_noise"]) for r in wide})
    fig, axes = plt.subplots(len(shapes), len(sig), figsize=(4.2 * len(sig), 3.2 * len(shapes)), squeeze=False)
    style = {"pca_k": ("PCA k sweep", "tab:blue"), "jet_k": ("jet k sweep", "tab:green"),
             "vcm_R": ("VCM radii", "tab:orange")}
    for i, shape in enumerate(shapes):
        for j, s in enumerate(sig):
            ax = axes[i][j]
            case = [r for r in wide if r["input"] == shape and float(r["p_noise"]) == s]
            for fam, (lab, color) in style.items():
                pts = sorted((r["seconds"], r["rms"]) for r in case if family(r["method"]) == fam)
                if pts:
                    ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-" if fam != "vcm_R" else "o",
                            color=color, markersize=3, linewidth=1, label=lab)
            for method, lab, color, marker in MAIN:
                if method in ("ours", "open3d_k18", "open3d_hybrid"):
                    for r in case:
                        if r["method"] == method:
                            ax.scatter([r["seconds"]], [r["rms"]], color=color, marker=marker,
                                       s=120 if method == "ours" else 40, label=lab, zorder=5)
            ax.set_xscale("log")
            ax.grid(True, which="both", alpha=0.3)
            ax.set_title(f"{shape}, σ = {s:g}", fontsize=9)
            if i == len(shapes) - 1:
                ax.set_xlabel("seconds (2 threads; VCM sequential)")
            if j == 0:
                ax.set_ylabel("RMS (deg)")
    axes[0][0].legend(fontsize=6)
    fig.suptitle("Normals, wide set: RMS error against time of every run (lower left is better)", fontsize=11)
    fig.tight_layout(rect=(0, 0, 1, 0.985))
    path = os.path.join(out, "normals_wide_error_vs_time.png")
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def speed(rows, out):
    sp = [r for r in rows if r.get("p_sweep") == "speed" and r.get("p_noise") == "0"]
    shapes = shapes_of(sp)
    if not shapes:
        return None
    fig, axes = plt.subplots(2, len(shapes), figsize=(5.5 * len(shapes), 8), squeeze=False)
    for j, shape in enumerate(shapes):
        for method, lab, color in (("ours", "ours (default)", "tab:red"), ("pcl_omp_k18", "PCL OMP k = 18", "tab:blue")):
            pts = sorted((r["points"], r["seconds"], r["rms"]) for r in sp if r["input"] == shape and r["method"] == method)
            axes[0][j].plot([p[0] for p in pts], [p[1] for p in pts], "o-", color=color, label=lab)
            axes[1][j].plot([p[0] for p in pts], [p[2] for p in pts], "o-", color=color, label=lab)
        ours = {r["points"]: r["seconds"] for r in sp if r["input"] == shape and r["method"] == "ours"}
        for r in sp:
            if r["input"] == shape and r["method"] == "pcl_omp_k18" and r["points"] in ours:
                axes[0][j].annotate(f"{r['seconds'] / ours[r['points']]:.2f}x", (r["points"], r["seconds"]),
                                    textcoords="offset points", xytext=(-10, 6), fontsize=8)
        axes[0][j].set_xscale("log")
        axes[0][j].set_yscale("log")
        axes[1][j].set_xscale("log")
        axes[0][j].set_title(f"{shape}: time (PCL / ours ratio written)", fontsize=10)
        axes[1][j].set_title(f"{shape}: RMS angle error", fontsize=10)
        axes[0][j].set_ylabel(f"wall seconds (best of {int(sp[0].get('repeats', 2))}, 2 threads)")
        axes[1][j].set_ylabel("RMS (deg)")
        for ax in (axes[0][j], axes[1][j]):
            ax.set_xlabel("points")
            ax.grid(True, which="both", alpha=0.3)
            ax.legend(fontsize=8)
    fig.suptitle("Normals speed sweep (clean mesh samples): ours against PCL NormalEstimationOMP k = 18", fontsize=11)
    fig.tight_layout()
    path = os.path.join(out, "normals_wide_speed.png")
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("csv")
    ap.add_argument("--out", default=".")
    ap.add_argument("--peers-from", help="an earlier run's CSV whose CGAL rows (jet_*, vcm_*) fill the cases "
                    "this run has none for (a --no-cgal rerun; same clouds, same seed)")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)
    rows = read(a.csv)
    if a.peers_from:
        have = {(r["input"], r.get("p_noise"), r["method"]) for r in rows}
        ours = {(r["input"], r.get("p_noise")) for r in rows if r.get("p_sweep") == "wide" and r["method"] == "ours"}
        rows += [r for r in read(a.peers_from)
                 if r.get("p_sweep") == "wide" and r["method"].startswith(("jet_", "vcm_"))
                 and (r["input"], r.get("p_noise")) in ours and (r["input"], r.get("p_noise"), r["method"]) not in have]
    for f in (rms_vs_noise, delta, error_vs_time, speed):
        p = f(rows, a.out)
        if p:
            print(p)


if __name__ == "__main__":
    main()
