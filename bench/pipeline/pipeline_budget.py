#!/usr/bin/env python3
"""Per-stage budget of apps/pclx_pipeline on 640x480 depth frames (2 cores).

Runs the app off-screen (every frame processed) and reads its per-frame stage times (--timings):
  stages  the 7-Scenes office frames (../shared/data, else generated 640x480 frames) with the
          stages switched on one after another: the frame rate each stage leaves;
  plan    HPR + normals only, on generated frames at 320x240 and 640x480, over VoxelGrid leaves:
          what reaches 30 fps;
and writes pipeline.csv (one row per run and frame) and pipeline_stage_times.png (stage time against
frame index, all stages on) into DIR, and prints the tables (also left in the work directory as
pipeline_budget.md) for docs/results/pipeline/summary.md.
  pipeline_budget.py --app APP --make-frames MAKE_IDC_FRAMES --out DIR [--shared DIR]
"""
import argparse
import csv
import os
import subprocess
import sys
import tempfile

STAGES = ["filter", "hpr", "normals", "surface", "octree"]


def run_app(args, source, flags, work, label):
    timings = os.path.join(work, label + ".csv")
    cmd = ["xvfb-run", "-a", args.app, *source, "--fps", "30", "--screenshot", os.path.join(work, label + ".png"),
           "--timings", timings, *flags]
    print("[pipeline_budget] " + label, file=sys.stderr, flush=True)
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    with open(timings) as f:
        return [{k: float(v) for k, v in row.items()} for row in csv.DictReader(f)]


def mean_ms(rows, skip=1):
    """Mean per stage over the frames after the first `skip` (warm-up)."""
    rows = rows[skip:] or rows
    return {s: sum(r[s + "_ms"] for r in rows) / len(rows) for s in STAGES}


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--app", required=True)
    ap.add_argument("--make-frames", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--shared", default=os.path.join(os.path.dirname(__file__), "../../../shared/data"))
    ap.add_argument("--frames", type=int, default=50)
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    work = tempfile.mkdtemp(prefix="pipeline_budget_")
    seven = os.path.join(args.shared, "rgbd", "7scenes-office")
    generated = {}
    for w, h in ((640, 480), (320, 240)):
        d = os.path.join(work, "frames_%dx%d" % (w, h))
        subprocess.run([args.make_frames, "--depth-png-dir", d, "--frames", str(args.frames), "--width", str(w),
                        "--height", str(h)], check=True, stdout=subprocess.DEVNULL)
        generated[(w, h)] = d
    if os.path.isdir(seven):
        room, room_name = seven, "7scenes-office (real, 640x480)"
    else:
        print("[pipeline_budget] ../shared/data not found: the stage table uses generated frames", file=sys.stderr)
        room, room_name = generated[(640, 480)], "generated orbit (640x480)"

    rows_out, stage_table, plan_table = [], [], []
    steps = [("filter", ["--no-hpr", "--no-normals", "--surface", "none", "--no-octree"]),
             ("+ hpr", ["--no-normals", "--surface", "none", "--no-octree"]),
             ("+ normals", ["--surface", "none", "--no-octree"]),
             ("+ surface (IDC)", ["--no-octree"]),
             ("+ octree", [])]
    full = None
    for label, flags in steps:
        rows = run_app(args, ["--depth-dir", room], flags, work, "stages_" + str(len(stage_table)))
        m = mean_ms(rows)
        stage_table.append((label, m))
        for r in rows:
            rows_out.append(["stages", room_name, label, "0.02"] + [r["frame"]] + [r[s + "_ms"] for s in STAGES])
        full = rows
    plans = [(room_name.split(" (")[0], 640, 480, room, ("0.02", "0.04", "0.08"))]
    plans += [("generated orbit", w, h, d, ("0.005", "0.01", "0.02", "0.04")) for (w, h), d in sorted(generated.items())]
    for name, w, h, d, voxels in plans:
        for voxel in voxels:
            rows = run_app(args, ["--depth-dir", d], ["--voxel", voxel, "--surface", "none", "--no-octree"], work,
                           "plan_%s_%dx%d_%s" % (name.replace(" ", "_"), w, h, voxel))
            plan_table.append((name, w, h, voxel, mean_ms(rows)))
            for r in rows:
                rows_out.append(["plan", "%s %dx%d" % (name, w, h), "hpr+normals", voxel] + [r["frame"]] +
                                [r[s + "_ms"] for s in STAGES])

    with open(os.path.join(args.out, "pipeline.csv"), "w", newline="") as f:
        wr = csv.writer(f)
        wr.writerow(["run", "input", "stages", "voxel", "frame"] + [s + "_ms" for s in STAGES])
        wr.writerows(rows_out)
    tables = os.path.join(work, "pipeline_budget.md")
    with open(tables, "w") as f:
        f.write("# pclx_pipeline: per-stage budget (2 cores, %d frames per run, first frame left out)\n\n" % args.frames)
        f.write("## Stages switched on one after another: %s\n\n" % room_name)
        f.write("| stages on | " + " | ".join(STAGES) + " | total ms | fps |\n|---|" + "---|" * (len(STAGES) + 2) + "\n")
        for label, m in stage_table:
            total = sum(m.values())
            f.write("| %s | %s | %.1f | %.1f |\n" % (label, " | ".join("%.1f" % m[s] for s in STAGES), total,
                                                   1000 / total if total else 0))
        slow = max(STAGES, key=lambda s: stage_table[-1][1][s])
        f.write("\nSlowest stage with everything on: **%s** (%.1f ms).\n\n" % (slow, stage_table[-1][1][slow]))
        f.write("## HPR + normals only: what reaches 30 fps (33.3 ms)\n\n")
        f.write("| frames | voxel (m) | filter | hpr | normals | total ms | fps |\n|---|---|---|---|---|---|---|\n")
        for name, w, h, voxel, m in plan_table:
            total = m["filter"] + m["hpr"] + m["normals"]
            f.write("| %s %dx%d | %s | %.1f | %.1f | %.1f | %.1f | %.1f |\n" % (name, w, h, voxel, m["filter"], m["hpr"],
                                                                           m["normals"], total, 1000 / total))
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        fig, ax = plt.subplots(figsize=(9, 4.5))
        frames = [r["frame"] for r in full]
        bottom = [0.0] * len(full)
        for s in STAGES:
            vals = [r[s + "_ms"] for r in full]
            ax.bar(frames, vals, bottom=bottom, label=s, width=0.9)
            bottom = [b + v for b, v in zip(bottom, vals)]
        ax.axhline(1000 / 30, color="k", lw=0.8, ls="--", label="30 fps")
        ax.set_xlabel("frame")
        ax.set_ylabel("ms")
        ax.set_title("pclx_pipeline, every stage on: %s" % room_name)
        ax.legend(ncol=3, fontsize=8)
        fig.tight_layout()
        fig.savefig(os.path.join(args.out, "pipeline_stage_times.png"), dpi=90)
    except ImportError:
        print("[pipeline_budget] matplotlib missing: no chart", file=sys.stderr)
    print(open(tables).read())
    return 0


if __name__ == "__main__":
    sys.exit(main())
