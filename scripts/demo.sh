#!/usr/bin/env bash
# The README's main job: installs Debian packages, builds (Release), and runs the demo on
# generated data: the HPR viewer off-screen on a generated scene (cloud and replayed depth
# frames), the benchmarks in their quick mode (peers in the same run), and the charts.
# Everything lands in ${PCLX_DEMO_OUT:-demo_output}/.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install-deps.sh
OUT=${PCLX_DEMO_OUT:-demo_output}
mkdir -p "$OUT/frames"

cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=Release
cmake --build build -j "$(nproc)"

echo "== generated scene: a sampled cloud and three Kinect-like depth frames"
./build/apps/hpr_viewer/make_scene --cloud "$OUT/scene.ply" --points 200000 \
  --dir "$OUT/frames" --frames 3 --width 640 --height 480

echo "== hpr_viewer (off-screen) on the cloud and on the frames through pcl::PCDGrabber"
xvfb-run -a ./build/apps/hpr_viewer/hpr_viewer --input "$OUT/scene.ply" --mesh --view-dir 1 -0.7 0.45 --up 0 0 1 \
  --screenshot "$OUT/hpr_scene.png" --output "$OUT/hpr_scene_visible.pcd"
xvfb-run -a ./build/apps/hpr_viewer/hpr_viewer --pcd-dir "$OUT/frames" --frames 3 \
  --screenshot "$OUT/hpr_frames.png"

echo "== benchmarks (quick mode; CSV in $OUT)"
./build/bench/bench_scenes --sizes 10000 100000 --csv "$OUT/scenes.csv" > /dev/null
./build/bench/hpr/bench_hpr --quick --csv "$OUT/hpr.csv" > /dev/null
if [ -x ./build/bench/normals/bench_normals ]; then
  ./build/bench/normals/bench_normals --csv "$OUT/normals.csv" > /dev/null
fi
if [ -x ./build/apps/normals_tool/normals_tool ] && [ -n "$(ls ./build/apps/normals_tool/ 2>/dev/null)" ]; then
  xvfb-run -a ./build/apps/normals_tool/normals_tool --input "$OUT/scene.ply" --output "$OUT/scene_normals.pcd" \
    --view --screenshot "$OUT/normals_scene.png" || echo "normals_tool demo failed (see above)"
fi

echo "== charts"
/usr/bin/python3 bench/plot.py "$OUT"/*.csv --out "$OUT/charts"
echo "demo.sh: pictures and charts are in $OUT/"
