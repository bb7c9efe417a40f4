#!/usr/bin/env python3
"""Charts of bench_rbf rows (pcl::RBFPOUReconstruction against PCL and Open3D).

  python3 bench/surface/rbf_charts.py docs/results/surface/surface.csv --out docs/results/surface

Reads rows with bench/plot.py's reader and draws
  rbf_error_vs_time_clean.png / _scan.png   Chamfer error against time, every method over its sweep
  rbf_error_vs_bad_normals.png              error and open edges against the share of flipped /
                                            perturbed normals
  rbf_error_vs_noise.png                    error against position noise
  rbf_noisy.png                             every shape at 100k points, clean and noisy: Chamfer,
                                            connected components and time against the noise
  rbf_error_vs_triangles.png                clean 100k: Chamfer against triangles, our grid sweep
                                            beside Open3D's depths
  rbf_time_memory_vs_points.png             time and peak memory against points (log-log)
  rbf_mcrbf.png                             small clouds: where MarchingCubesRBF runs, and stops
Rows whose run failed (status=oom / timeout / crash / empty) are drawn as crosses on the x axis,
never as values. SPECS (below) also lets bench/plot.py draw simple versions when a
bench/surface/charts.py imports it.
"""
import argparse
import collections
import os
import sys
import textwrap

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
from plot import read_rows  # noqa: E402

# For bench/plot.py (series = method only).
SPECS = [
    dict(name="rbf_plot_error_vs_time", title="Surface: Chamfer error / diagonal against time (clean, main sweep)",
         x="seconds", y="chamfer_rel", series="method", logx=True, logy=True,
         where=dict(sweep="main", cond="clean", status="ok"), split="input", scatter=True),
    dict(name="rbf_plot_time_vs_points", title="Surface: time against points (size sweep)",
         x="points", y="seconds", series="method", logx=True, logy=True,
         where=dict(sweep="size", status="ok"), split="input"),
]

STYLE = {  # label: (colour, marker)
    "RBF-POU, true normals": ("tab:red", "o"),
    "RBF-POU, true normals, interpolating (setNoiseLevel (0))": ("lightcoral", "x"),
    "RBF-POU, our normals + MST": ("tab:orange", "s"),
    "RBF-POU, PCA normals + MST": ("tab:brown", "D"),
    "RBF-POU + MST re-orientation": ("tab:pink", "P"),
    "RBF-POU, the given normals (neighbour vote)": ("tab:red", "o"),
    "Open3D screened Poisson": ("tab:blue", "^"),
    "Open3D Poisson, 5 % low density trimmed": ("tab:cyan", "v"),
    "PCL Poisson": ("tab:green", "<"),
    "PCL MarchingCubesHoppe": ("tab:purple", ">"),
    "PCL MarchingCubesRBF": ("tab:gray", "X"),
}


def label(r):
    m = r["method"]
    if m == "rbf" and r.get("p_sweep") == "robust":
        return "RBF-POU, the given normals (neighbour vote)"
    if m == "rbf" and r.get("p_fit") == "interpolate":
        return "RBF-POU, true normals, interpolating (setNoiseLevel (0))"
    if m == "rbf":
        return {"true": "RBF-POU, true normals", "ours": "RBF-POU, our normals + MST",
                "pca": "RBF-POU, PCA normals + MST"}[r.get("p_normals", "true")]
    return {"rbf_mst": "RBF-POU + MST re-orientation", "o3d_poisson": "Open3D screened Poisson",
            "o3d_poisson_trim": "Open3D Poisson, 5 % low density trimmed", "pcl_poisson": "PCL Poisson",
            "pcl_mc_hoppe": "PCL MarchingCubesHoppe", "pcl_mc_rbf": "PCL MarchingCubesRBF"}.get(m, m)


def setting(r):
    """The swept parameter of a row, as a short tag."""
    for key, tag in (("p_depth", "d"), ("p_res", "r"), ("p_grid", "h=")):
        if key in r:
            v = r[key]
            if key == "p_grid":
                return "" if v == "auto" else f"h={v:g}s"
            return f"{tag}{int(v)}"
    return ""


def ok(r):
    return r.get("p_status") == "ok" and isinstance(r.get("chamfer_rel"), float)


def by_label(rows):
    groups = collections.OrderedDict((k, []) for k in STYLE)
    for r in rows:
        groups.setdefault(label(r), []).append(r)
    return [(k, v) for k, v in groups.items() if v]


def suptitle(fig, text):
    width = fig.get_size_inches()[0]
    fig.suptitle("\n".join(textwrap.wrap(text, int(width * 13))), fontsize=10)


def legend_outside(fig, axes):
    handles, labels = {}, []
    for ax in axes:
        for h, lab in zip(*ax.get_legend_handles_labels()):
            if lab not in handles:
                handles[lab] = h
                labels.append(lab)
    fig.legend([handles[lab] for lab in labels], labels, loc="lower center", ncol=min(4, len(labels)),
               fontsize=8, frameon=False)


def save_chart(fig, axes, title, out, name, margins, dpi=110):
    """Title, the legend below the panels, layout (bottom / top margins) and the PNG; returns its path."""
    suptitle(fig, title)
    legend_outside(fig, axes.flat)
    fig.tight_layout(rect=(0, margins[0], 1, margins[1]))
    path = os.path.join(out, name)
    fig.savefig(path, dpi=dpi)
    plt.close(fig)
    return path


def error_vs_time(rows, cond, out):
    # The full run's main sweep; a --quick run (the demo) has one size per input plus a smaller
    # MarchingCubesRBF case, left out so that one panel compares one cloud.
    main = [r for r in rows if r.get("p_sweep") == "main" and r.get("p_cond") == cond]
    if not main:
        quick = [r for r in rows if r.get("p_sweep") == "quick" and r.get("p_cond") == cond]
        largest = {}
        for r in quick:
            largest[r["input"]] = max(largest.get(r["input"], 0), r["points"])
        main = [r for r in quick if r["points"] == largest[r["input"]]]
    rows = main
    inputs = list(collections.OrderedDict.fromkeys(r["input"] for r in rows))
    if not inputs:
        return None
    ncols = min(3, len(inputs))
    nrows = (len(inputs) + ncols - 1) // ncols
    fig, axes = plt.subplots(nrows, ncols, figsize=(max(12, 6 * ncols), 4.6 * nrows + 1.4), squeeze=False)
    for ax in axes.flat[len(inputs):]:
        ax.set_visible(False)
    for ax, name in zip(axes.flat, inputs):
        irows = [r for r in rows if r["input"] == name]
        for lab, lrows in by_label(irows):
            good = sorted([r for r in lrows if ok(r)], key=lambda r: r["seconds"])
            if not good:
                continue
            c, mk = STYLE.get(lab, ("k", "o"))
            xs = [r["seconds"] for r in good]
            ys = [r["chamfer_rel"] for r in good]
            ax.plot(xs, ys, color=c, lw=0.8, alpha=0.6)
            closed = [r.get("watertight") == 1.0 for r in good]
            ax.scatter([x for x, w in zip(xs, closed) if w], [y for y, w in zip(ys, closed) if w],
                       color=c, marker=mk, s=36, label=lab, zorder=3)
            ax.scatter([x for x, w in zip(xs, closed) if not w], [y for y, w in zip(ys, closed) if not w],
                       facecolors="none", edgecolors=c, marker=mk, s=36, zorder=3)
            for r in good:
                if setting(r):
                    ax.annotate(setting(r), (r["seconds"], r["chamfer_rel"]), fontsize=6, color=c,
                                xytext=(3, 2), textcoords="offset points")
        failed = sorted({label(r) for r in irows if r.get("p_status") != "ok"})
        if failed:
            ax.text(0.01, 0.01, "no result: " + ", ".join(f.replace("PCL ", "") for f in failed), fontsize=6,
                    transform=ax.transAxes, va="bottom")
        n = int(irows[0]["points"])
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("time, s (normals + reconstruction; log)")
        ax.set_ylabel("Chamfer distance / bbox diagonal (log)")
        ax.set_title(f"{name}, {n // 1000}k points", fontsize=10)
        ax.grid(True, which="both", alpha=0.3)
    what = "clean samples" if cond == "clean" else \
        "scan-like samples (density 1→0.2, 5 % shadow holes, noise 0.1 % of the diagonal)"
    return save_chart(fig, axes, f"Error against time, {what}: filled = watertight, hollow = open or non-manifold; "
                      "labels: Poisson depth d, marching-cubes cells r, RBF grid h (× spacing s)",
                      out, f"rbf_error_vs_time_{cond}.png", (0.08, 0.93))


def sweep_lines(ax, rows, x, y, xscale=1.0):
    for lab, lrows in by_label(rows):
        c, mk = STYLE.get(lab, ("k", "o"))
        good = sorted([r for r in lrows if ok(r) and isinstance(r.get(y), float)], key=lambda r: r[x])
        if good:
            ax.plot([r[x] * xscale for r in good], [max(r[y], 1e-9) for r in good], color=c, marker=mk,
                    label=lab, ms=5)
        bad = [r for r in lrows if r.get("p_status") != "ok"]
        if bad:
            ax.scatter([r[x] * xscale for r in bad], [ax.get_ylim()[0]] * len(bad), color=c, marker="x",
                       s=50, clip_on=False, zorder=4)


def robustness(rows, out):
    rows = [r for r in rows if r.get("p_sweep") == "robust"]
    if not rows:
        return None
    for r in rows:
        r["bad_pct"] = 100.0 * r.get("p_bad", 0.0)
        r["bad_edges"] = r.get("boundary_edges", 0.0) + r.get("nonmanifold_edges", 0.0) \
            if isinstance(r.get("boundary_edges"), float) else None
    inputs = list(collections.OrderedDict.fromkeys(r["input"] for r in rows))
    panels = [(i, kind) for i in inputs for kind in ("flip", "perturb")]
    metrics = [("chamfer_rel", "Chamfer / diagonal", True), ("hausdorff_rel", "Hausdorff / diagonal", True),
               ("bad_edges", "open + non-manifold edges", "symlog")]
    fig, axes = plt.subplots(len(metrics), len(panels), figsize=(4.8 * len(panels), 3.6 * len(metrics) + 0.8),
                             squeeze=False)
    for j, (name, kind) in enumerate(panels):
        # share 0 % is the clean run: it belongs to both the flip and the perturb line
        prow = [r for r in rows if r["input"] == name and (r.get("p_cond") == kind or r["bad_pct"] == 0)]
        for i, (m, mlabel, logy) in enumerate(metrics):
            ax = axes[i][j]
            if logy == "symlog":
                ax.set_yscale("symlog", linthresh=1)
            elif logy:
                ax.set_yscale("log")
            sweep_lines(ax, [r for r in prow if r.get(m) is not None], "bad_pct", m)
            ax.set_xscale("symlog", linthresh=1)
            ax.set_xticks([0, 1, 5, 20])
            ax.set_xticklabels(["0", "1", "5", "20"])
            ax.set_xlabel(f"{'flipped' if kind == 'flip' else 'randomly re-drawn'} normals, % of points")
            ax.set_ylabel(mlabel)
            ax.grid(True, which="both", alpha=0.3)
            if i == 0:
                n = int(prow[0]["points"]) if prow else 0
                ax.set_title(f"{name}, {n // 1000}k points: {'flipped' if kind == 'flip' else 'perturbed'} normals",
                             fontsize=10)
    return save_chart(fig, axes, "Robustness to bad normals (peers get the same corrupted normals; Poisson depth 8 / 7, "
                      "Hoppe 96 cells)",
                      out, "rbf_error_vs_bad_normals.png", (0.05, 0.97))


def noise(rows, out):
    rows = [r for r in rows if r.get("p_sweep") == "noise"]
    if not rows:
        return None
    inputs = list(collections.OrderedDict.fromkeys(r["input"] for r in rows))
    fig, axes = plt.subplots(2, len(inputs), figsize=(max(12, 6 * len(inputs)), 9), squeeze=False)
    for j, name in enumerate(inputs):
        irows = [r for r in rows if r["input"] == name]
        for i, (m, mlabel) in enumerate((("chamfer_rel", "Chamfer / diagonal"), ("hausdorff_rel", "Hausdorff / diagonal"))):
            ax = axes[i][j]
            ax.set_yscale("log")
            sweep_lines(ax, irows, "p_noise", m, xscale=100.0)
            ax.set_xlabel("position noise σ, % of the bbox diagonal")
            ax.set_ylabel(mlabel)
            ax.grid(True, which="both", alpha=0.3)
            if i == 0:
                ax.set_title(f"{name}, {int(irows[0]['points']) // 1000}k points", fontsize=10)
    return save_chart(fig, axes, "Error against position noise (true normals of the clean surface, except 'our normals': "
                      "estimated from the noisy points)",
                      out, "rbf_error_vs_noise.png", (0.06, 0.96))


def noisy(rows, out):
    rows = [r for r in rows if r.get("p_sweep") == "noisy" and r.get("p_grid", "auto") == "auto"]
    if not rows:
        return None
    for r in rows:
        r["noise_pct"] = 100.0 * r.get("p_noise", 0.0)
    inputs = list(collections.OrderedDict.fromkeys(r["input"] for r in rows))
    metrics = [("chamfer_rel", "Chamfer / diagonal", "log"), ("components", "connected components", "symlog"),
               ("seconds", "seconds", "log")]
    fig, axes = plt.subplots(len(metrics), len(inputs), figsize=(3.6 * len(inputs) + 1, 3.2 * len(metrics) + 1.2),
                             squeeze=False)
    for j, name in enumerate(inputs):
        irows = [r for r in rows if r["input"] == name]
        for lab, lrows in by_label(irows):
            c, mk = STYLE.get(lab, ("k", "o"))
            # Open3D at its best depth for each noise level (lowest Chamfer), as one line.
            if lab.startswith("Open3D"):
                best = {}
                for r in lrows:
                    if ok(r) and (r["noise_pct"] not in best or r["chamfer_rel"] < best[r["noise_pct"]]["chamfer_rel"]):
                        best[r["noise_pct"]] = r
                lrows = [best[k] for k in sorted(best)]
                lab += " (best depth of 8–10)"
            good = sorted([r for r in lrows if ok(r)], key=lambda r: r["noise_pct"])
            for i, (m, _, _) in enumerate(metrics):
                pts = [(r["noise_pct"], r[m]) for r in good if isinstance(r.get(m), float)]
                if pts:
                    axes[i][j].plot([p[0] for p in pts], [max(p[1], 1e-9) for p in pts], color=c, marker=mk,
                                    label=lab, ms=5)
        for i, (m, mlabel, scale) in enumerate(metrics):
            ax = axes[i][j]
            if scale == "symlog":
                ax.set_yscale("symlog", linthresh=1)
            else:
                ax.set_yscale(scale)
            ax.set_xticks([0, 0.25, 0.5])
            ax.set_xlabel("noise σ, % of the diagonal")
            ax.set_ylabel(mlabel)
            ax.grid(True, which="both", alpha=0.3)
            if i == 0:
                ax.set_title(f"{name}, {int(irows[0]['points']) // 1000}k points", fontsize=10)
    return save_chart(fig, axes, "Noisy samples (true normals): RBF-POU with its defaults (fits smooth by the measured noise) "
                      "and interpolating, beside Open3D's screened Poisson at its best depth",
                      out, "rbf_noisy.png", (0.06, 0.95), dpi=100)


def grid_factor(r):
    """Our grid h in mean spacings (auto = 1.5)."""
    return 1.5 if r.get("p_grid") == "auto" else float(r["p_grid"])


def error_vs_triangles(rows, out):
    rows = [r for r in rows if r.get("p_sweep") == "noisy" and r.get("p_cond") == "clean" and ok(r)]
    if not rows:
        return None
    inputs = list(collections.OrderedDict.fromkeys(r["input"] for r in rows))
    cols = min(3, len(inputs))
    nrows = (len(inputs) + cols - 1) // cols
    fig, axes = plt.subplots(nrows, cols, figsize=(4.6 * cols, 3.8 * nrows + 1.0), squeeze=False)
    for j, name in enumerate(inputs):
        ax = axes[j // cols][j % cols]
        irows = [r for r in rows if r["input"] == name]
        for lab, lrows in by_label(irows):
            c, mk = STYLE.get(lab, ("k", "o"))
            key = grid_factor if lab.startswith("RBF") else (lambda r: -r["p_depth"])
            lrows = sorted(lrows, key=key)
            ax.plot([r["triangles"] for r in lrows], [r["chamfer_rel"] for r in lrows], color=c, marker=mk, ms=5,
                    label=lab + (" (h = 1.5 … 4.5 spacings)" if lab.startswith("RBF") else " (depths 8–10)"))
            for r in lrows:
                tag = f"h={grid_factor(r):g}" if lab.startswith("RBF") else f"d{int(r['p_depth'])}"
                ax.annotate(tag, (r["triangles"], r["chamfer_rel"]), fontsize=7, xytext=(3, 3),
                            textcoords="offset points")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("triangles")
        ax.set_ylabel("Chamfer / diagonal")
        ax.grid(True, which="both", alpha=0.3)
        ax.set_title(f"{name}, {int(irows[0]['points']) // 1000}k points, clean", fontsize=10)
    for j in range(len(inputs), nrows * cols):
        axes[j // cols][j % cols].set_visible(False)
    return save_chart(fig, axes, "Chamfer error against triangles (true normals): RBF-POU over its grid (h in mean "
                      "spacings; default 1.5) beside Open3D's screened Poisson at depths 8–10, same run",
                      out, "rbf_error_vs_triangles.png", (0.08, 0.94), dpi=100)


def size(rows, out):
    # The default grid only: the coarser grids at 1M belong to the triangles-at-equal-Chamfer view.
    rows = [r for r in rows if r.get("p_sweep") == "size" and r["method"] != "o3d_poisson_trim"
            and r.get("p_grid", "auto") in ("auto", None)]
    if not rows:
        return None
    inputs = list(collections.OrderedDict.fromkeys(r["input"] for r in rows))
    fig, axes = plt.subplots(2, len(inputs), figsize=(max(12, 6.5 * len(inputs)), 10), squeeze=False)
    for j, name in enumerate(inputs):
        irows = [r for r in rows if r["input"] == name]
        # one line per method label and Poisson depth choice by size; depth 11 is its own line
        for r in irows:
            if r["method"].startswith("o3d") and r.get("p_depth") == 11:
                r["_extra"] = " (depth 11)"
        for i, (y, ylab) in enumerate((("seconds", "time, s (normals + reconstruction)"),
                                       ("peak_mb", "peak memory, MB (VmHWM over the input)"))):
            ax = axes[i][j]
            ax.set_xscale("log")
            ax.set_yscale("log")
            groups = collections.OrderedDict()
            for r in irows:
                groups.setdefault(label(r) + r.get("_extra", ""), []).append(r)
            for lab, lrows in groups.items():
                c, mk = STYLE.get(lab.replace(" (depth 11)", ""), ("k", "o"))
                good = sorted([r for r in lrows if r.get("p_status") == "ok" and isinstance(r.get(y), float)],
                              key=lambda r: r["points"])
                if good:
                    ax.plot([r["points"] for r in good], [r[y] for r in good], color=c, marker=mk,
                            ls="--" if "depth 11" in lab else "-", label=lab, ms=5)
            ax.set_xlabel("input points (log)")
            ax.set_ylabel(ylab + " (log)")
            ax.grid(True, which="both", alpha=0.3)
            lo = ax.get_ylim()[0]
            short = {"PCL MarchingCubesRBF": "MC-RBF", "PCL MarchingCubesHoppe": "Hoppe", "PCL Poisson": "PCL Poisson",
                     "RBF-POU, our normals + MST": "ours + MST", "Open3D screened Poisson": "Open3D"}
            failed = collections.defaultdict(list)
            for r in irows:
                if r.get("p_status") != "ok":
                    failed[r["points"]].append(f"{short.get(label(r), label(r))}: {r['p_status']}")
            for x, texts in failed.items():
                ax.scatter([x], [lo], color="k", marker="x", s=40, clip_on=False, zorder=5)
                ax.annotate("\n".join(sorted(texts)), (x, lo), fontsize=6, xytext=(0, 6), textcoords="offset points",
                            ha="center", va="bottom")
            if y == "peak_mb":
                xs = sorted({r["points"] for r in irows})
                ax.plot(xs, [x * 1024 / 2 ** 20 for x in xs], "k:", lw=1, label="1 KB per point (target)")
            if i == 0:
                ax.set_title(f"{name}: time against points", fontsize=10)
            else:
                ax.set_title(f"{name}: peak memory against points", fontsize=10)
    return save_chart(fig, axes, "Cost against size (clean samples; Poisson depth 8 / 9 / 10 by size, crosses: run "
                      "failed or capped)",
                      out, "rbf_time_memory_vs_points.png", (0.07, 0.96))


def mcrbf(rows, out):
    rows = [r for r in rows if r.get("p_sweep") == "mcrbf" and not r["method"].endswith("_trim")]
    if not rows:
        return None
    inputs = list(collections.OrderedDict.fromkeys(r["input"] for r in rows))
    fig, axes = plt.subplots(2, len(inputs), figsize=(max(12, 6 * len(inputs)), 9), squeeze=False)
    for j, name in enumerate(inputs):
        irows = [r for r in rows if r["input"] == name]
        for i, (y, ylab) in enumerate((("seconds", "time, s (log)"), ("chamfer_rel", "Chamfer / diagonal (log)"))):
            ax = axes[i][j]
            groups = collections.OrderedDict()
            for r in irows:
                groups.setdefault(label(r) + (" " + setting(r) if setting(r) else ""), []).append(r)
            for lab, lrows in groups.items():
                base = lab.split(" h=")[0].split(" r")[0].split(" d")[0]
                c, mk = STYLE.get(base, ("k", "o"))
                good = sorted([r for r in lrows if ok(r)], key=lambda r: r["points"])
                # grid variants of one method: one colour, a line style and marker per setting
                tag = setting(lrows[0])
                ls, mk = {"h=2.5s": (":", "v"), "h=0.75s": ("--", "s"), "h=0.35s": ("-.", "D"),
                          "r32": (":", mk)}.get(tag, ("-", mk))
                if good:
                    ax.plot([r["points"] for r in good], [r[y] for r in good], color=c, marker=mk, ls=ls,
                            label=lab, ms=5)
            ax.set_xscale("log")
            ax.set_yscale("log")
            lo = ax.get_ylim()[0]
            for r in irows:
                if r.get("p_status") != "ok":
                    ax.scatter([r["points"]], [lo], color="tab:gray", marker="x", s=60, clip_on=False, zorder=5)
                    ax.annotate(f"MC-RBF {setting(r)}: {r['p_status']}", (r["points"], lo), fontsize=6,
                                rotation=90, xytext=(2, 4), textcoords="offset points")
            ax.set_xlabel("input points (log)")
            ax.set_ylabel(ylab)
            ax.grid(True, which="both", alpha=0.3)
            ax.set_title(f"{name}: {'time' if i == 0 else 'error'} against points (small clouds)", fontsize=10)
    return save_chart(fig, axes, "Where PCL MarchingCubesRBF (dense 2N×2N system, fullPivLu) runs: beside RBF-POU (grid h in "
                      "spacings s), Open3D Poisson and Hoppe on small clouds; crosses: MarchingCubesRBF failed",
                      out, "rbf_mcrbf.png", (0.08, 0.95))


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("csv", nargs="+")
    ap.add_argument("--out", default="docs/results/surface")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    rows = [r for r in read_rows(args.csv) if r["module"] == "surface" and "p_sweep" in r]  # bench_rbf rows, not bench_idc's
    if not rows:
        sys.exit("rbf_charts.py: no surface rows in " + " ".join(args.csv))
    written = [p for p in (error_vs_time(rows, "clean", args.out), error_vs_time(rows, "scan", args.out),
                           robustness(rows, args.out), noise(rows, args.out), noisy(rows, args.out),
                           error_vs_triangles(rows, args.out),
                           size(rows, args.out),
                           mcrbf(rows, args.out)) if p]
    for p in written:
        print("wrote", p)
    if not written:
        sys.exit("rbf_charts.py: no chart could be drawn")


if __name__ == "__main__":
    main()
