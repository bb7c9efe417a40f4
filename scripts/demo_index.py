#!/usr/bin/env python3
"""Lists what the demo wrote, one caption per file, and writes index.html beside it.

  python3 scripts/demo_index.py demo_output

Pictures come first (what an app showed), then charts (from bench/plot.py, captioned
with their chart titles), then the CSV and point files. Files without a caption are
listed by name so nothing the demo wrote is hidden.
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


def main():
    if len(sys.argv) != 2 or not os.path.isdir(sys.argv[1]):
        sys.exit("usage: demo_index.py OUTPUT_DIR")
    out = sys.argv[1]
    titles = chart_titles()
    pictures, charts, data = [], [], []
    for name in sorted(os.listdir(out)):
        path = os.path.join(out, name)
        if name == "index.html":
            continue
        if name == "charts" and os.path.isdir(path):
            for c in sorted(os.listdir(path)):
                if c.endswith(".png"):
                    charts.append(("charts/" + c, titles.get(c, c[:-4].replace("_", " "))))
        elif name.endswith("_growth") and os.path.isdir(path):
            # A series of pictures (e.g. a hierarchy growing): shown in order, one caption each.
            frames = sorted(f for f in os.listdir(path) if f.endswith(".png"))
            for i, f in enumerate(frames):
                pictures.append((f"{name}/{f}", f"{CAPTIONS.get(name, name)} ({i + 1} of {len(frames)})"))
        elif name.endswith(".png"):
            pictures.append((name, CAPTIONS.get(name, name)))
        else:
            data.append((name + ("/" if os.path.isdir(path) else ""), CAPTIONS.get(name, "")))

    # Known outputs in the order the demo makes them, then anything else by name.
    order = {name: i for i, name in enumerate(CAPTIONS)}
    pictures.sort(key=lambda item: (order.get(item[0].split("/")[0], len(order)), item[0]))
    data.sort(key=lambda item: (order.get(item[0].rstrip("/"), len(order)), item[0]))

    print(f"demo.sh wrote to {out}/ (open {out}/index.html to see everything on one page):")
    for group, items in (("pictures", pictures), ("charts", charts), ("data", data)):
        if items:
            print(f"  {group}:")
            for name, cap in items:
                print(f"    {name:<40} {cap}")

    parts = ["<!doctype html><html><head><meta charset='utf-8'><title>pclx demo</title>",
             "<style>body{font-family:sans-serif;max-width:1400px;margin:auto;padding:1em;background:#fafafa}"
             "figure{display:inline-block;vertical-align:top;margin:0.6em;max-width:660px}"
             "img{max-width:100%;border:1px solid #ccc;background:#fff}"
             "figcaption{font-size:0.9em;color:#333}td{padding:0.2em 1em 0.2em 0}</style></head><body>",
             "<h1>pclx demo output</h1>",
             "<p>Written by <code>scripts/demo.sh</code> on generated data. Pictures are what the apps "
             "rendered off-screen; charts come from the benchmarks' quick runs, with the peers measured in "
             "the same run.</p>"]
    for heading, items in (("Pictures", pictures), ("Charts", charts)):
        if not items:
            continue
        parts.append(f"<h2>{heading}</h2>")
        for name, cap in items:
            n, c = html.escape(name), html.escape(cap)
            parts.append(f"<figure><a href='{n}'><img src='{n}' alt='{c}'></a><figcaption>{c}</figcaption></figure>")
    if data:
        parts.append("<h2>Data</h2><table>")
        for name, cap in data:
            parts.append(f"<tr><td><a href='{html.escape(name)}'>{html.escape(name)}</a></td>"
                         f"<td>{html.escape(cap)}</td></tr>")
        parts.append("</table>")
    parts.append("</body></html>")
    with open(os.path.join(out, "index.html"), "w") as f:
        f.write("\n".join(parts))


if __name__ == "__main__":
    main()
