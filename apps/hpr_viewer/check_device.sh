#!/usr/bin/env bash
# hpr_viewer's live path: pcl::io::OpenNI2Grabber on the pclx virtual camera (installed by
# scripts/install-openni2-driver.sh), off-screen under Xvfb.
#   check_device.sh <hpr_viewer> <make_scene> <xvfb-run> <work dir>
# 1. the generated scene (no configuration): frames processed, a screenshot written;
# 2. recorded 16-bit PNG frames (PCLX_VIRTUAL_CAMERA_DIR): the frame size is the recording's;
# 3. the folder removed mid-stream (an unplugged camera): exit 1 with a clear message, no hang.
set -uo pipefail
viewer=$1 make_scene=$2 xvfb=$3 work=$4
rm -rf "$work" && mkdir -p "$work"
fail () { echo "FAIL: $*" >&2; exit 1; }
# Runs the viewer under Xvfb; <xvfb-run> is apps/common/xvfb_app.sh, which exits with the
# viewer's own status (not xvfb-run's, whose temp-dir cleanup can fail after the viewer).
xrun () { local t=$1; shift; timeout "$t" "$xvfb" -a "$viewer" "$@" 2>&1; }

# The virtual camera must not be switched off by the caller's environment.
unset PCLX_VIRTUAL_CAMERA PCLX_VIRTUAL_CAMERA_DIR
export PCLX_VIRTUAL_CAMERA_CONF="$work/none.conf"   # no system config either

echo "== 1. generated scene"
out=$(xrun 120 --device "" --frames 3 --width 640 --height 320 \
  --screenshot "$work/device.png" --output "$work/device_visible.pcd") || fail "viewer failed: $out"
echo "$out"
grep -q "frame 2: " <<<"$out" || fail "fewer than 3 frames processed"
grep -q "307200 points" <<<"$out" || fail "a 640x480 frame should have 307200 valid points (generated scene)"
[ "$(stat -c %s "$work/device.png")" -gt 10000 ] || fail "screenshot missing or blank"
[ -s "$work/device_visible.pcd" ] || fail "no visible points written"
if grep -qiE "warn|deprecat|failed" <<<"$out"; then fail "console warnings: $out"; fi

echo "== 2. recorded PNG frames"
"$make_scene" --depth-png-dir "$work/rec" --frames 3 --width 320 --height 240 >/dev/null || fail "make_scene"
out=$(PCLX_VIRTUAL_CAMERA_DIR="$work/rec" xrun 120 --device "" --frames 2 \
  --width 640 --height 320 --screenshot "$work/recorded.png") || fail "viewer on recording failed: $out"
echo "$out"
grep -q "frame 1: " <<<"$out" || fail "fewer than 2 recorded frames processed"
# The frames are the recording's (320x240: at most 76800 valid pixels), not the generated scene.
n=$(grep -o "frame 0: [0-9]* points" <<<"$out" | grep -o "[0-9][0-9]* points" | grep -o "[0-9]*")
[ -n "$n" ] && [ "$n" -gt 1000 ] && [ "$n" -le 76800 ] || fail "recorded frame 0 has $n points (want 1000..76800)"

echo "== 3. unplugged mid-stream"
cp -r "$work/rec" "$work/unplug"
(sleep 4; rm -rf "$work/unplug") &
start=$(date +%s)
out=$(PCLX_VIRTUAL_CAMERA_DIR="$work/unplug" xrun 60 --device "" --frames 100000 \
  --width 320 --height 160 --screenshot "$work/unplug.png")
rc=$?
wait
echo "$out" | tail -5
[ "$rc" = 1 ] || fail "expected exit 1 after the unplug, got '$rc'"
grep -q "hpr_viewer: .*stopped delivering frames" <<<"$out" || fail "no clear error after the unplug: $out"
[ $(( $(date +%s) - start )) -lt 40 ] || fail "took too long to notice the unplug"
echo "device checks passed"
