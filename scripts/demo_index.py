#!/usr/bin/env python3
"""Writes index.html beside what the demo wrote and prints one line per module.

  python3 scripts/demo_index.py demo_output

The page groups the outputs by module: the pictures an app rendered, then the charts of the
module's benchmark rows, as a grid of thumbnails that open full size, then its data files.
Files without a caption are shown by name so nothing the demo wrote is hidden.
"""
import html
import importlib.util
import os
import sys

# What each fixed demo output shows; charts take their titles from bench/*/charts.py.
CAPTIONS = {
    "hpr_scene.png": "hpr_viewer on the generated cloud: left what the observer sees, right the scene "
                     "from the side (visible orange, hidden grey, viewpoint red)",
    "hpr_frames.png": "hpr_viewer on recorded depth frames replayed through pcl::PCDGrabber",
    "hpr_depth_frames.png": "hpr_viewer on 16-bit PNG depth frames (7-Scenes layout) replayed as a folder",
    "hpr_device.png": "hpr_viewer live from the pclx virtual OpenNI2 camera through "
                      "pcl::io::OpenNI2Grabber (the same path a Kinect or Xtion takes)",
    "normals_scene.png": "normals_tool on the generated cloud: PlanarOctreeNormalEstimation, MST-oriented, "
                         "coloured by planar region",
    "rbf_scene.png": "rbf_reconstruct on the generated cloud: our normals and MST orientation, then "
                     "RBFPOUReconstruction (partition of unity of local RBF fits, sparse-band marching cubes)",
    "idc_scan.png": "idc_scan: 24 posed Kinect-like depth frames of a torus around a sphere fused by "
                    "IncrementalDualContouring (1 cm leaves, octree simplification at 1 mm)",
    "idc_mesh.ply": "the adaptive mesh idc_scan fused from the generated depth frames",
    "idc_frames": "24 posed 16-bit PNG depth frames (7-Scenes layout) of the generated object, idc_scan's input",
    "surface": "surface benchmark rows (quick mode): RBF-POU against PCL/Open3D Poisson, MarchingCubesHoppe/RBF "
               "(rbf.csv); incremental dual contouring against Open3D's TSDF (idc.csv, idc_frames.csv)",
    "pipeline_device.png": "pclx_pipeline live from the virtual OpenNI2 camera: the frame, PassThrough + "
                           "VoxelGrid + HPRFilter, normals with MST orientation, IncrementalDualContouring "
                           "across frames, the OMiCroN front over the accumulated map, and the stage timings",
    "pipeline": "pclx_pipeline's milliseconds per stage and frame on the virtual camera (timings.csv)",
    "omicron_growth": "omicron_viewer growth pictures: the front every 2 rendered frames while the octree is built",
    "omicron_final.png": "omicron_viewer: the OMiCroN front drawn as splats once the octree is built "
                         "(2M points, coloured by normal)",
    "scene.ply": "the generated scene cloud (torus and sphere on a plate)",
    "hpr_scene_visible.pcd": "the points hpr_viewer found visible in the scene cloud",
    "scene_mesh.ply": "the mesh rbf_reconstruct made from the generated cloud",
    "scene_normals.pcd": "the scene cloud with normals from normals_tool",
    "scenes.csv": "ground-truth throughput (sampling, ray casting, distances)",
    "hpr.csv": "HPR benchmark rows (quick mode): ours against Open3D's HiddenPointRemoval, same run",
    "normals.csv": "normals benchmark rows (quick mode): ours against PCL and Open3D, same run",
    "omicron.csv": "OMiCroN benchmark rows (quick mode): ours against pcl_outofcore_process, a top-down "
                   "octree and PCL's octree, same run",
    "frames": "three Kinect-like depth frames as organized PCD (pcl::PCDGrabber input)",
    "omicron_cloud.pcd": "the 2M-point cloud omicron_viewer builds",
    "omicron_potree": "the OMiCroN hierarchy as Potree 2.0 files (metadata.json, hierarchy.bin, octree.bin)",
    "depth_frames": "the same frames as 16-bit PNG depth in millimetres (7-Scenes layout)",
}


# Charts drawn by bench/surface/*_charts.py (not bench/plot.py specs).
SURFACE_CHARTS = {
    "rbf_error_vs_time_clean.png": "RBF-POU pipeline against PCL / Open3D Poisson and MarchingCubesHoppe / RBF: "
                                   "Chamfer error against time, clean samples",
    "rbf_error_vs_time_scan.png": "the same on scanner-like samples (noise, holes, uneven density)",
    "rbf_error_vs_bad_normals.png": "error and open edges against the share of flipped / perturbed normals",
    "rbf_error_vs_noise.png": "error against position noise",
    "rbf_time_memory_vs_points.png": "time and peak memory against point count (how the cost grows)",
    "rbf_mcrbf.png": "where PCL's MarchingCubesRBF (dense 2N x 2N system) runs, and where it stops",
    "idc_error_vs_triangles.png": "incremental dual contouring against Open3D's TSDF: error against triangles",
    "idc_error_vs_eps.png": "incremental dual contouring: error and triangles against the simplification error eps",
    "idc_time_vs_detail.png": "time per frame against detail, IDC and Open3D's TSDF in the same run",
    "idc_time_vs_frame.png": "time per frame against frame index (does the cost grow with the map?)",
}


def chart_titles():
    """Chart name -> title, from the specs bench/plot.py draws."""
    here = os.path.dirname(os.path.abspath(__file__))
    bench = os.path.join(here, "..", "bench")
    titles = dict(SURFACE_CHARTS)
    for entry in sorted(os.listdir(bench)):
        path = os.path.join(bench, entry, "charts.py")
        if not os.path.isfile(path):
            continue
        spec = importlib.util.spec_from_file_location(f"charts_{entry}", path)
        mod = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(mod)
        for s in getattr(mod, "SPECS", []):
            titles[s["name"] + ".png"] = s.get("title", s["name"])
    return titles


# Page sections in order: (title, file-name prefixes that belong to it).
MODULES = [
    ("HPRFilter: hidden point removal", ("hpr", "scene.ply", "frames", "depth_frames")),
    ("PlanarOctreeNormalEstimation and MSTNormalOrientation", ("normals", "scene_normals")),
    ("RBFPOUReconstruction", ("rbf", "scene_mesh", "surface")),
    ("IncrementalDualContouring", ("idc",)),
    ("ObliqueCutOctree (OMiCroN) and its Potree output", ("omicron",)),
    ("pclx_pipeline: every module on one camera", ("pipeline",)),
    ("Ground truth used by the benchmarks", ("scenes",)),
]
OTHER = "Other outputs"


def module_of(name):
    base = name.split("/")[-1] if name.startswith("charts/") else name.split("/")[0]
    for title, prefixes in MODULES:
        if any(base.startswith(p) for p in prefixes):
            return title
    return OTHER


def collect(out, titles):
    """(module -> pictures, charts, data) with captions, in the demo's order."""
    groups = {title: ([], [], []) for title, _ in MODULES + [(OTHER, ())]}
    for name in sorted(os.listdir(out)):
        path = os.path.join(out, name)
        if name in ("index.html", "logs"):
            continue
        if name == "charts" and os.path.isdir(path):
            for c in sorted(os.listdir(path)):
                if c.endswith(".png"):
                    groups[module_of("charts/" + c)][1].append(
                        ("charts/" + c, titles.get(c, c[:-4].replace("_", " "))))
        elif name.endswith("_growth") and os.path.isdir(path):
            # A series of pictures (a hierarchy growing): in order, one caption each.
            frames = sorted(f for f in os.listdir(path) if f.endswith(".png"))
            for i, f in enumerate(frames):
                groups[module_of(name)][0].append(
                    (f"{name}/{f}", f"{CAPTIONS.get(name, name)} ({i + 1} of {len(frames)})"))
        elif name.endswith(".png"):
            groups[module_of(name)][0].append((name, CAPTIONS.get(name, name)))
        else:
            groups[module_of(name)][2].append((name + ("/" if os.path.isdir(path) else ""), CAPTIONS.get(name, "")))
    order = {name: i for i, name in enumerate(CAPTIONS)}
    for pictures, _, data in groups.values():
        pictures.sort(key=lambda item: (order.get(item[0].split("/")[0], len(order)), item[0]))
        data.sort(key=lambda item: (order.get(item[0].rstrip("/"), len(order)), item[0]))
    return {k: v for k, v in groups.items() if any(v)}


STYLE = ("body{font-family:sans-serif;max-width:1500px;margin:auto;padding:1em;background:#fafafa;color:#222}"
         "h2{margin-top:1.6em;border-bottom:1px solid #ccc}"
         ".grid{display:grid;grid-template-columns:repeat(auto-fill,minmax(330px,1fr));gap:1em}"
         "figure{margin:0;background:#fff;border:1px solid #ddd;padding:0.4em}"
         "figure img{width:100%;height:220px;object-fit:contain;display:block}"
         "figure.chart{background:#f4f8ff}"
         "figcaption{font-size:0.85em;margin-top:0.3em}td{padding:0.15em 1em 0.15em 0;font-size:0.9em}")


def figure(name, caption, cls=""):
    n, c = html.escape(name), html.escape(caption)
    return (f"<figure class='{cls}'><a href='{n}'><img src='{n}' alt='{c}' loading='lazy'></a>"
            f"<figcaption>{c}</figcaption></figure>")


def page(groups):
    parts = ["<!doctype html><html><head><meta charset='utf-8'><title>pclx demo</title>",
             f"<style>{STYLE}</style></head><body>",
             "<h1>pclx demo output</h1>",
             "<p>Written by <code>scripts/demo.sh</code> on generated data. Each module shows what its app "
             "rendered off-screen, then the charts of its benchmark's quick run (blue background; the peers "
             "ran in the same run). Click a thumbnail for the full picture; each step's console output is in "
             "<a href='logs/'>logs/</a>.</p>"]
    for title, (pictures, charts, data) in groups.items():
        parts.append(f"<h2>{html.escape(title)}</h2><div class='grid'>")
        parts += [figure(n, c) for n, c in pictures] + [figure(n, c, "chart") for n, c in charts]
        parts.append("</div>")
        if data:
            parts.append("<table>")
            for name, cap in data:
                parts.append(f"<tr><td><a href='{html.escape(name)}'>{html.escape(name)}</a></td>"
                             f"<td>{html.escape(cap)}</td></tr>")
            parts.append("</table>")
    parts.append("</body></html>")
    return "\n".join(parts)


def main():
    if len(sys.argv) != 2 or not os.path.isdir(sys.argv[1]):
        sys.exit("usage: demo_index.py OUTPUT_DIR")
    out = sys.argv[1]
    groups = collect(out, chart_titles())
    with open(os.path.join(out, "index.html"), "w") as f:
        f.write(page(groups))
    print(f"demo.sh wrote {out}/index.html:")
    for title, (pictures, charts, data) in groups.items():
        print(f"  {title}: {len(pictures)} pictures, {len(charts)} charts, {len(data)} data files")


if __name__ == "__main__":
    main()
