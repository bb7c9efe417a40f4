#!/usr/bin/env bash
# pclx_pipeline live: pcl::io::OpenNI2Grabber on the pclx virtual camera (installed by
# scripts/install-openni2-driver.sh), every stage on, off-screen under Xvfb.
#   check_device.sh <pclx_pipeline> <xvfb_app.sh> <work dir>
set -uo pipefail
app=$1 xvfb=$2 work=$3
rm -rf "$work" && mkdir -p "$work"
fail () { echo "FAIL: $*" >&2; exit 1; }
# The generated scene, whatever the caller's environment or system configuration says.
unset PCLX_VIRTUAL_CAMERA PCLX_VIRTUAL_CAMERA_DIR
export PCLX_VIRTUAL_CAMERA_CONF="$work/none.conf"
out=$(timeout 180 "$xvfb" -a "$app" --device "" --frames 4 --octree-every 2 --screenshot "$work/device.png" \
  --output "$work/out" 2>&1) || fail "pipeline failed: $out"
echo "$out"
grep -q "frame 3: " <<<"$out" || fail "fewer than 4 frames processed"
grep -qE "frame 3: .* 307200 points, [0-9]+ after the depth range, [1-9][0-9]* after the voxel grid and HPR, [1-9][0-9]* mesh triangles, [1-9][0-9]* in the map" <<<"$out" \
  || fail "a 640x480 frame through every stage should leave points, triangles and a map"
grep -q "slowest stage: " <<<"$out" || fail "no stage summary"
[ "$(stat -c %s "$work/device.png")" -gt 20000 ] || fail "screenshot missing or blank"
for f in filtered.pcd visible.pcd normals.pcd map.pcd surface.ply potree/metadata.json; do
  [ -s "$work/out/$f" ] || fail "missing output $f"
done
if grep -qiE "warn|deprecat|failed" <<<"$out"; then fail "console warnings: $out"; fi
echo "device check passed"
