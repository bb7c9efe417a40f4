#!/usr/bin/env bash
# The README's main job: installs the Debian packages, builds (Release), installs the OpenNI2
# virtual camera and runs every app and the benchmarks' quick mode on generated data. Pictures,
# charts, CSV rows and meshes land in ${PCLX_DEMO_OUT:-demo_output}/, shown on one page in
# index.html; each step's own output goes to logs/<step>.log there, and the console gets one
# line per step.
set -euo pipefail
cd "$(dirname "$0")/.."
OUT=${PCLX_DEMO_OUT:-demo_output}
LOGS="$OUT/logs"
rm -rf "$OUT/frames" "$OUT/depth_frames" "$OUT/charts" "$OUT/idc_frames" "$OUT/omicron_growth" \
  "$OUT/omicron_potree" "$LOGS"
mkdir -p "$OUT/frames" "$OUT/depth_frames" "$OUT/omicron_growth" "$OUT/pipeline" "$OUT/surface" "$LOGS"

# step NAME DESCRIPTION -- COMMAND...: runs COMMAND with its output in logs/NAME.log and prints
# one line with the time it took; a failure prints the log's tail and stops the demo.
step () {
  local name=$1 what=$2 start=$SECONDS
  shift 3
  printf '%-58s' "$what"
  if "$@" > "$LOGS/$name.log" 2>&1; then
    printf ' %4d s\n' $((SECONDS - start))
  else
    printf ' failed\n'
    tail -n 30 "$LOGS/$name.log"
    echo "demo.sh: '$what' failed; the whole output is in $LOGS/$name.log" >&2
    exit 1
  fi
}
offscreen () { xvfb-run -a "$@"; }
# The virtual camera replays its generated room unless PCLX_VIRTUAL_CAMERA_DIR names a folder.
live () { env -u PCLX_VIRTUAL_CAMERA_DIR xvfb-run -a "$@"; }
B=./build/apps

echo "pclx demo: outputs in $OUT/, each step's log in $LOGS/"
step deps "Debian packages" -- ./scripts/install-deps.sh
step build "build (Release, ninja)" -- bash -c \
  'cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release && cmake --build build -j "$(nproc)"'
step driver "OpenNI2 virtual camera driver" -- ./scripts/install-openni2-driver.sh build

step scene "generated scene: a 200k cloud, 3 depth frames (PCD, PNG)" -- \
  $B/hpr_viewer/make_scene --cloud "$OUT/scene.ply" --points 200000 --dir "$OUT/frames" \
  --depth-png-dir "$OUT/depth_frames" --frames 3 --width 640 --height 480
step hpr_scene "hpr_viewer: HPRFilter on the cloud" -- offscreen $B/hpr_viewer/hpr_viewer \
  --input "$OUT/scene.ply" --mesh --view-dir 1 -0.7 0.45 --up 0 0 1 \
  --screenshot "$OUT/hpr_scene.png" --output "$OUT/hpr_scene_visible.pcd"
step hpr_frames "hpr_viewer: PCD frames through pcl::PCDGrabber" -- offscreen $B/hpr_viewer/hpr_viewer \
  --pcd-dir "$OUT/frames" --frames 3 --screenshot "$OUT/hpr_frames.png"
step hpr_depth "hpr_viewer: 16-bit PNG depth frames" -- offscreen $B/hpr_viewer/hpr_viewer \
  --depth-dir "$OUT/depth_frames" --frames 3 --screenshot "$OUT/hpr_depth_frames.png"
step hpr_device "hpr_viewer: live from the virtual OpenNI2 camera" -- live $B/hpr_viewer/hpr_viewer \
  --device "" --frames 3 --screenshot "$OUT/hpr_device.png"
step normals "normals_tool: PlanarOctreeNormalEstimation + MST" -- offscreen $B/normals_tool/normals_tool \
  --input "$OUT/scene.ply" --output "$OUT/scene_normals.pcd" --orient mst --view --color region \
  --screenshot "$OUT/normals_scene.png"
step rbf "rbf_reconstruct: normals, MST, RBFPOUReconstruction" -- offscreen $B/rbf_reconstruct/rbf_reconstruct \
  "$OUT/scene.ply" --output "$OUT/scene_mesh.ply" --screenshot "$OUT/rbf_scene.png"
step idc_frames "make_idc_frames: 24 posed depth frames of an object" -- $B/idc_scan/make_idc_frames \
  --depth-png-dir "$OUT/idc_frames" --frames 24 --width 640 --height 480
step idc "idc_scan: IncrementalDualContouring over the frames" -- offscreen $B/idc_scan/idc_scan \
  --depth-dir "$OUT/idc_frames" --leaf 0.01 --epsilon 0.001 --output "$OUT/idc_mesh.ply" \
  --screenshot "$OUT/idc_scan.png"
step pipeline "pclx_pipeline: every module on the virtual camera" -- live $B/pclx_pipeline/pclx_pipeline \
  --device "" --frames 8 --screenshot "$OUT/pipeline_device.png" --timings "$OUT/pipeline/timings.csv"
step omicron_cloud "make_omicron_cloud: a 2M-point cloud" -- $B/omicron_viewer/make_omicron_cloud \
  --points 2000000 --color --out "$OUT/omicron_cloud.pcd"
step omicron "omicron_viewer: the LOD octree drawn while it is built" -- offscreen \
  $B/omicron_viewer/omicron_viewer "$OUT/omicron_cloud.pcd" --screenshot-every 2 \
  --growth-prefix "$OUT/omicron_growth/growth" --screenshot "$OUT/omicron_final.png" --output "$OUT/omicron_potree"

step bench_scenes "bench_scenes: ground-truth throughput" -- ./build/bench/bench_scenes --sizes 10000 100000 \
  --csv "$OUT/scenes.csv"
step bench_hpr "bench_hpr --quick: HPR beside Open3D" -- ./build/bench/hpr/bench_hpr --quick --csv "$OUT/hpr.csv"
step bench_normals "bench_normals: normals beside PCL and Open3D" -- ./build/bench/normals/bench_normals \
  --csv "$OUT/normals.csv"
step bench_omicron "bench_omicron --quick: beside pcl_outofcore and PCL" -- ./build/bench/omicron/bench_omicron \
  --quick --csv "$OUT/omicron.csv"
step bench_rbf "bench_rbf --quick: RBF-POU beside Poisson" -- ./build/bench/surface/bench_rbf --quick \
  --csv "$OUT/surface/rbf.csv"
step bench_idc "bench_idc --quick: IDC beside Open3D's TSDF" -- ./build/bench/surface/bench_idc --quick \
  --csv "$OUT/surface/idc.csv" --frames-csv "$OUT/surface/idc_frames.csv"
step charts "charts of the benchmark rows" -- bash -c "/usr/bin/python3 bench/plot.py $OUT/*.csv --out $OUT/charts \
  && /usr/bin/python3 bench/surface/rbf_charts.py $OUT/surface/rbf.csv --out $OUT/charts \
  && /usr/bin/python3 bench/surface/idc_charts.py $OUT/surface/idc.csv $OUT/surface/idc_frames.csv $OUT/charts"
/usr/bin/python3 scripts/demo_index.py "$OUT"
