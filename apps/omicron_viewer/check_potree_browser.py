#!/usr/bin/env python3
"""Our Potree output in a real loader: potree-core 2.0 in headless Chromium (swiftshader GL).

A generated coloured cloud goes through `omicron_viewer --output`; the folder is served on
127.0.0.1 (with HTTP ranges) and loaded by potree-core from one camera, and the same cloud is
rendered by VTK (potree_reference) from that camera. The check fails unless
  - the loader reports no error,
  - the root and at least two levels below it are shown,
  - every shown node holds the points hierarchy.bin says it stores,
  - at least 5 % of the points are shown at the loader's default point budget,
  - the drawn points' pixel box matches VTK's rendering of the same points within a few pixels,
  - a 5M-point budget loads without error,
  - a cloud with intensity (and no rgb) loads without error and is drawn, each shown node's
    decoded intensities having the min, max and sum of its stored values.
potree-core and three are installed with npm into --npm-dir (kept between runs).
"""
import argparse
import importlib.util
import json
import math
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import time

POTREE_CORE, THREE = "potree-core@2.0.15", "three@0.187.0"
WIDTH, HEIGHT, FOV = 640, 480, 50.0
BOX_TOLERANCE_PX = 3
MIN_SHOWN = 0.05


def run(cmd, **kw):
    print("+", " ".join(cmd), flush=True)
    return subprocess.run(cmd, check=True, **kw)


def install_loader(npm_dir):
    if os.path.exists(os.path.join(npm_dir, "node_modules", "potree-core", "dist", "index.js")):
        return
    os.makedirs(npm_dir, exist_ok=True)
    run(["npm", "install", "--prefix", npm_dir, "--no-audit", "--no-fund", "--loglevel=error", POTREE_CORE, THREE])


def camera_for(metadata):
    """A camera looking at the stored points' box from above and in front, framing it."""
    lo = metadata["attributes"][0]["min"]
    hi = metadata["attributes"][0]["max"]
    centre = [0.5 * (a + b) for a, b in zip(lo, hi)]
    radius = 0.5 * math.dist(lo, hi)
    direction = [0.35, 0.45, 1.0]
    norm = math.sqrt(sum(d * d for d in direction))
    distance = 1.05 * radius / math.sin(math.radians(FOV / 2))
    eye = [c + distance * d / norm for c, d in zip(centre, direction)]
    return {"eye": eye, "at": centre, "up": [0.0, 1.0, 0.0],
            "near": max(1e-3, distance - 2 * radius), "far": distance + 2 * radius}


def write_shown_points(folder, meta, records, names, path):
    """The points of the named nodes, decoded from octree.bin, as an ASCII PCD."""
    bpp = sum(a["size"] for a in meta["attributes"])
    with open(os.path.join(folder, "octree.bin"), "rb") as f:
        octree = f.read()
    rows = []
    for name in names:
        _, _, points, offset, _ = records[name]
        for k in range(points):
            q = struct.unpack_from("<iii", octree, offset + k * bpp)
            rows.append("%.9g %.9g %.9g" % tuple(q[a] * meta["scale"][a] + meta["offset"][a] for a in range(3)))
    with open(path, "w") as f:
        f.write("VERSION .7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH %d\nHEIGHT 1\n"
                "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS %d\nDATA ascii\n" % (len(rows), len(rows)))
        f.write("\n".join(rows) + "\n")


def stored_intensity_stats(folder, meta, record):
    """Min, max and sum of a node's stored float intensities, decoded from octree.bin."""
    names = [a["name"] for a in meta["attributes"]]
    at = sum(a["size"] for a in meta["attributes"][:names.index("intensity")])
    bpp = sum(a["size"] for a in meta["attributes"])
    _, _, points, offset, _ = record
    with open(os.path.join(folder, "octree.bin"), "rb") as f:
        f.seek(offset)
        data = f.read(points * bpp)
    values = [struct.unpack_from("<f", data, k * bpp + at)[0] for k in range(points)]
    return [min(values), max(values), math.fsum(values)]


def check_intensity(args, fmt, site):
    """A cloud with intensity through omicron_viewer into potree-core: failures as strings."""
    cloud = os.path.join(args.work, "intensity.pcd")
    run([args.make_cloud, "--points", "100000", "--intensity", "--out", cloud], stdout=subprocess.DEVNULL)
    folder = os.path.join(site, "potree_intensity")
    run([args.viewer, cloud, "--no-render", "--output", folder], stdout=subprocess.DEVNULL)
    with open(os.path.join(folder, "metadata.json")) as f:
        meta = json.load(f)
    with open(os.path.join(folder, "hierarchy.bin"), "rb") as f:
        h = meta["hierarchy"]
        records = fmt.parse_hierarchy(f.read(), h["firstChunkSize"], h["stepSize"])
    seen = load_in_browser(args, site, "potree_intensity", camera_for(meta), "browser_intensity")
    nodes = seen.get("visibleNodes", [])
    failures = ["intensity cloud: the loader reported errors: %s" % seen["errors"][:5]] if seen["errors"] else []
    if not nodes:
        failures.append("intensity cloud: no node shown")
    if seen.get("lit", 0) < 1000:
        failures.append("intensity cloud: %d lit pixels (the page colours nodes without rgb)" % seen.get("lit", 0))
    for n in nodes:
        want = stored_intensity_stats(folder, meta, records[n["name"]]) if n["name"] in records else None
        got = n.get("intensity")
        if got is None or want is None or any(abs(a - b) > 1e-6 * max(1.0, abs(b)) for a, b in zip(got, want)):
            failures.append("intensity cloud, node %s: decoded intensity min, max, sum %s, stored %s"
                            % (n["name"], n.get("intensity"), want))
    print("potree-core, intensity cloud: %d nodes shown, %d points; intensity attribute %s"
          % (len(nodes), seen.get("numVisiblePoints", 0), meta["attributes"][-1]))
    return failures


def vtk_box(args, cloud, cam, png):
    """potree_reference's pixel box of `cloud` from the camera."""
    cmd = [args.xvfb, args.reference, cloud, "--width", str(WIDTH), "--height", str(HEIGHT), "--fov", str(FOV),
           "--near", str(cam["near"]), "--far", str(cam["far"]), "--eye", *map(str, cam["eye"]),
           "--at", *map(str, cam["at"]), "--up", *map(str, cam["up"]), "--png", png]
    return json.loads(subprocess.run(cmd, check=True, capture_output=True, text=True).stdout.splitlines()[-1])


def load_in_browser(args, site, cloud, cam, name, budget=None):
    """Serves `site`, opens check.html in Chromium, returns what the page posted."""
    result = os.path.join(args.work, name + ".json")
    for f in (result, result + ".png"):
        if os.path.exists(f):
            os.remove(f)
    server = subprocess.Popen(["node", os.path.join(args.page, "server.js"), site, "0", result],
                              stdout=subprocess.PIPE, text=True)
    port = int(server.stdout.readline())
    fmt = lambda v: ",".join("%.9g" % x for x in v)
    url = ("http://127.0.0.1:%d/check.html?cloud=/%s&w=%d&h=%d&fov=%g&near=%.9g&far=%.9g&eye=%s&at=%s&up=%s"
           % (port, cloud, WIDTH, HEIGHT, FOV, cam["near"], cam["far"], fmt(cam["eye"]), fmt(cam["at"]), fmt(cam["up"])))
    if budget:
        url += "&budget=%d" % budget
    profile = os.path.join(args.work, "chromium-profile")
    # A killed browser leaves its singleton folder in TMPDIR: a folder of its own, removed below.
    # Not the work folder: the singleton's socket path must stay under 108 bytes.
    browser_tmp = tempfile.mkdtemp(prefix="pclx-chromium-")
    with open(os.path.join(args.work, name + ".chromium.log"), "w") as log:
        browser = subprocess.Popen([args.chromium, "--headless=new", "--no-sandbox", "--use-gl=angle",
                                    "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--no-first-run",
                                    "--user-data-dir=" + profile, "--window-size=%d,%d" % (WIDTH, HEIGHT), url],
                                   stdout=log, stderr=log, env=dict(os.environ, TMPDIR=browser_tmp))
        try:
            server.wait(timeout=120)
        except subprocess.TimeoutExpired:
            server.kill()
        browser.kill()
        browser.wait()
    shutil.rmtree(browser_tmp, ignore_errors=True)
    if not os.path.exists(result):
        raise SystemExit("FAILED: %s: the page posted no result within 120 s (see %s.chromium.log)" % (name, name))
    with open(result) as f:
        return json.load(f)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    for opt in ("viewer", "make-cloud", "reference", "xvfb", "work", "page", "npm-dir", "format-checker"):
        ap.add_argument("--" + opt, required=True)
    ap.add_argument("--chromium", default=shutil.which("chromium") or "chromium")
    ap.add_argument("--points", type=int, default=400000)
    args = ap.parse_args()
    shutil.rmtree(args.work, ignore_errors=True)
    os.makedirs(args.work)
    spec = importlib.util.spec_from_file_location("potree_format_check", args.format_checker)
    fmt = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(fmt)

    cloud = os.path.join(args.work, "cloud.pcd")
    run([args.make_cloud, "--points", str(args.points), "--color", "--out", cloud], stdout=subprocess.DEVNULL)
    site = os.path.join(args.work, "site")
    run([args.viewer, cloud, "--no-render", "--output", os.path.join(site, "potree")], stdout=subprocess.DEVNULL)
    install_loader(args.npm_dir)
    os.symlink(os.path.join(os.path.abspath(args.npm_dir), "node_modules"), os.path.join(site, "node_modules"))
    for page in ("check.html", "fill_colour.js"):
        shutil.copy(os.path.join(args.page, page), site)

    with open(os.path.join(site, "potree", "metadata.json")) as f:
        meta = json.load(f)
    with open(os.path.join(site, "potree", "hierarchy.bin"), "rb") as f:
        h = meta["hierarchy"]
        records = fmt.parse_hierarchy(f.read(), h["firstChunkSize"], h["stepSize"])
    cam = camera_for(meta)

    t0 = time.time()
    seen = load_in_browser(args, site, "potree", cam, "browser")
    seconds = time.time() - t0
    nodes = seen.get("visibleNodes", [])
    # VTK draws the points of the nodes the loader showed (decoded by the independent parser),
    # and, for the picture, the whole cloud.
    shown_pcd = os.path.join(args.work, "shown.pcd")
    write_shown_points(os.path.join(site, "potree"), meta, records,
                       [n["name"] for n in nodes if n["name"] in records], shown_pcd)
    ref = vtk_box(args, shown_pcd, cam, os.path.join(args.work, "vtk.png"))
    whole = vtk_box(args, cloud, cam, os.path.join(args.work, "vtk_whole.png"))
    big = load_in_browser(args, site, "potree", cam, "browser_5M", budget=5000000)

    failures = []
    levels = sorted({n["level"] for n in nodes})
    shown = seen.get("numVisiblePoints", 0)
    print("potree-core: %d nodes shown (levels %s), %d of %d points (%.1f %%), box %s, %d frames, %.1f s; "
          "VTK box of those points %s (of the whole cloud %s); %d nodes stored; 5M budget: %d points shown"
          % (len(nodes), levels, shown, meta["points"], 100.0 * shown / meta["points"], seen.get("bbox"),
             seen.get("frames", 0), seconds, ref["bbox"], whole["bbox"], len(records), big.get("numVisiblePoints", 0)))
    if seen["errors"]:
        failures.append("the loader reported errors: %s" % seen["errors"][:5])
    if "r" not in {n["name"] for n in nodes} or len(levels) < 3:
        failures.append("the root and two levels below it are not all shown (levels %s)" % levels)
    for n in nodes:
        stored = records.get(n["name"])
        if stored is None or n["numPoints"] != stored[2] or n["drawn"] != stored[2]:
            failures.append("node %s: loader %d, drawn %d, hierarchy.bin %s points"
                            % (n["name"], n["numPoints"], n["drawn"], stored and stored[2]))
    if shown < MIN_SHOWN * meta["points"]:
        failures.append("only %.2f %% of the points shown at the default budget" % (100.0 * shown / meta["points"]))
    box, ref_box = seen.get("bbox", [0, 0, -1, -1]), ref["bbox"]
    if any(abs(a - b) > BOX_TOLERANCE_PX for a, b in zip(box, ref_box)):
        failures.append("drawn box %s differs from VTK's %s by more than %d px" % (box, ref_box, BOX_TOLERANCE_PX))
    if big["errors"]:
        failures.append("a 5M-point budget gave errors: %s" % big["errors"][:5])
    if big.get("numVisiblePoints", 0) < shown:
        failures.append("a 5M-point budget showed fewer points (%d) than the default" % big.get("numVisiblePoints", 0))
    failures += check_intensity(args, fmt, site)
    for f in failures:
        print("FAILED:", f)
    if failures:
        return 1
    print("OK: browser.json.png (potree-core) and vtk.png (VTK) in", args.work)
    return 0


if __name__ == "__main__":
    sys.exit(main())
