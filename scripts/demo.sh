#!/usr/bin/env bash
# The README's main job: installs Debian packages, builds (Release), installs the OpenNI2
# virtual camera, and runs the demo on generated data: hpr_viewer off-screen on a generated
# cloud, on recorded frames (PCD through pcl::PCDGrabber, 16-bit PNG depth) and live from the
# virtual camera through pcl::io::OpenNI2Grabber; normals_tool; rbf_reconstruct (normals, MST,
# RBF partition of unity, mesh); idc_scan (posed depth frames fused into an adaptive mesh by
# incremental dual contouring); pclx_pipeline (every module on the virtual camera's frames);
# omicron_viewer growing an LOD
# octree (growth pictures, Potree output); the benchmarks in their quick
# mode (peers in the same run) and their charts. Everything lands in ${PCLX_DEMO_OUT:-demo_output}/,
# listed at the end and on one page in index.html.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
OUT=${PCLX_DEMO_OUT:-demo_output}
rm -rf "$OUT/frames" "$OUT/depth_frames" "$OUT/charts"
mkdir -p "$OUT/frames" "$OUT/depth_frames"

cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release > /dev/null
cmake --build build -j "$(nproc)"
./scripts/install-openni2-driver.sh build

echo "== generated scene: a sampled cloud and three Kinect-like depth frames (PCD and 16-bit PNG)"
./build/apps/hpr_viewer/make_scene --cloud "$OUT/scene.ply" --points 200000 \
  --dir "$OUT/frames" --depth-png-dir "$OUT/depth_frames" --frames 3 --width 640 --height 480

echo "== hpr_viewer (off-screen): the cloud, the PCD frames, the PNG depth frames, the virtual camera"
xvfb-run -a ./build/apps/hpr_viewer/hpr_viewer --input "$OUT/scene.ply" --mesh --view-dir 1 -0.7 0.45 --up 0 0 1 \
  --screenshot "$OUT/hpr_scene.png" --output "$OUT/hpr_scene_visible.pcd"
xvfb-run -a ./build/apps/hpr_viewer/hpr_viewer --pcd-dir "$OUT/frames" --frames 3 \
  --screenshot "$OUT/hpr_frames.png"
xvfb-run -a ./build/apps/hpr_viewer/hpr_viewer --depth-dir "$OUT/depth_frames" --frames 3 \
  --screenshot "$OUT/hpr_depth_frames.png"
# The live path: the pclx virtual camera replays its generated room (set PCLX_VIRTUAL_CAMERA_DIR
# to a 7-Scenes folder to replay that instead); a Kinect or Xtion takes the same path.
env -u PCLX_VIRTUAL_CAMERA_DIR xvfb-run -a ./build/apps/hpr_viewer/hpr_viewer --device "" --frames 3 \
  --screenshot "$OUT/hpr_device.png"

echo "== normals_tool (off-screen) on the cloud"
xvfb-run -a ./build/apps/normals_tool/normals_tool --input "$OUT/scene.ply" --output "$OUT/scene_normals.pcd" \
  --orient mst --view --color region --screenshot "$OUT/normals_scene.png"

echo "== rbf_reconstruct (off-screen): our normals + MST, then the RBF partition of unity, on the cloud"
xvfb-run -a ./build/apps/rbf_reconstruct/rbf_reconstruct "$OUT/scene.ply" --output "$OUT/scene_mesh.ply" \
  --screenshot "$OUT/rbf_scene.png"

echo "== idc_scan (off-screen): 24 posed Kinect-like depth frames of a generated object fused into an adaptive mesh"
rm -rf "$OUT/idc_frames"
./build/apps/idc_scan/make_idc_frames --depth-png-dir "$OUT/idc_frames" --frames 24 --width 640 --height 480 > /dev/null
xvfb-run -a ./build/apps/idc_scan/idc_scan --depth-dir "$OUT/idc_frames" --leaf 0.01 --epsilon 0.001 \
  --output "$OUT/idc_mesh.ply" --screenshot "$OUT/idc_scan.png"

echo "== pclx_pipeline (off-screen): the virtual camera through filters, HPR, normals, IDC and OMiCroN"
# Its per-frame stage times go to a folder of their own (the bench CSVs below are charted together).
mkdir -p "$OUT/pipeline"
env -u PCLX_VIRTUAL_CAMERA_DIR xvfb-run -a ./build/apps/pclx_pipeline/pclx_pipeline --device "" --frames 8 \
  --screenshot "$OUT/pipeline_device.png" --timings "$OUT/pipeline/timings.csv" | tail -7

echo "== omicron_viewer (off-screen): a 2M-point cloud drawn while its LOD octree is built"
rm -rf "$OUT/omicron_growth" "$OUT/omicron_potree" && mkdir -p "$OUT/omicron_growth"
./build/apps/omicron_viewer/make_omicron_cloud --points 2000000 --color --out "$OUT/omicron_cloud.pcd" > /dev/null
xvfb-run -a ./build/apps/omicron_viewer/omicron_viewer "$OUT/omicron_cloud.pcd" --screenshot-every 2 \
  --growth-prefix "$OUT/omicron_growth/growth" --screenshot "$OUT/omicron_final.png" --output "$OUT/omicron_potree"

echo "== benchmarks (quick mode; CSV in $OUT)"
./build/bench/bench_scenes --sizes 10000 100000 --csv "$OUT/scenes.csv" > /dev/null
./build/bench/hpr/bench_hpr --quick --csv "$OUT/hpr.csv" > /dev/null
./build/bench/normals/bench_normals --csv "$OUT/normals.csv" > /dev/null
if [ -x ./build/bench/omicron/bench_omicron ]; then
  ./build/bench/omicron/bench_omicron --quick --csv "$OUT/omicron.csv" > /dev/null
fi

# Surface benches keep their CSV apart: their charts come from bench/surface/*_charts.py.
mkdir -p "$OUT/surface"
./build/bench/surface/bench_rbf --quick --csv "$OUT/surface/rbf.csv" > /dev/null
./build/bench/surface/bench_idc --quick --csv "$OUT/surface/idc.csv" --frames-csv "$OUT/surface/idc_frames.csv" > /dev/null

echo "== charts"
/usr/bin/python3 bench/plot.py "$OUT"/*.csv --out "$OUT/charts" > /dev/null
/usr/bin/python3 bench/surface/rbf_charts.py "$OUT/surface/rbf.csv" --out "$OUT/charts" > /dev/null
/usr/bin/python3 bench/surface/idc_charts.py "$OUT/surface/idc.csv" "$OUT/surface/idc_frames.csv" "$OUT/charts" > /dev/null
/usr/bin/python3 scripts/demo_index.py "$OUT"
