#!/usr/bin/env bash
# Fuzzes the app kit's cloud loader (apps/common) with libFuzzer + ASan for a bounded time:
#   scripts/fuzz-loader.sh [seconds]   (default 300)
# Builds with clang into build-fuzz/, seeds a corpus with small valid PCD / PLY / XYZ /
# depth-PNG files generated here, and reports crashes, leaks and timeouts (inputs in
# build-fuzz/findings/). Not part of CI. Turn each finding into a test: copy it to
# apps/common/test/regressions/ (test_appkit loads every file there and expects LoadError).
set -euo pipefail
cd "$(dirname "$0")/.."
SECONDS_TOTAL=${1:-300}
OUT=build-fuzz
mkdir -p "$OUT/corpus" "$OUT/findings"
CXX=${CXX_FUZZ:-clang++}
command -v "$CXX" >/dev/null || { echo "fuzz-loader: $CXX not found (apt-get install clang)"; exit 1; }

src=(apps/common/fuzz/fuzz_loader.cpp apps/common/src/file_check.cpp apps/common/src/cloud_loader.cpp
     apps/common/src/depth_frames.cpp)
bin=$OUT/fuzz_loader
if [ ! -x "$bin" ] || [ -n "$(find "${src[@]}" apps/common/include -newer "$bin" 2>/dev/null)" ]; then
  echo "== building $bin with $CXX (libFuzzer + ASan)"
  # Eigen's own aligned malloc under ASan would not match PCL's plain malloc (see test.sh).
  "$CXX" -std=c++17 -g -O1 -fsanitize=fuzzer,address -fno-omit-frame-pointer -DEIGEN_MALLOC_ALREADY_ALIGNED=1 \
    -Iapps/common/include -isystem /usr/include/pcl-1.13 -isystem /usr/include/eigen3 \
    "${src[@]}" -o "$bin" -lpcl_io -lpcl_common -lpng -lboost_system
fi

echo "== seeding $OUT/corpus"
# The first byte picks the format: 0 PCD, 1 PLY, 2 XYZ, 3 depth PNG.
seed() { { printf "\\x$1"; cat; } > "$OUT/corpus/$2"; }
seed 00 ascii.pcd <<'PCD'
# .PCD v0.7
VERSION 0.7
FIELDS x y z rgb
SIZE 4 4 4 4
TYPE F F F U
COUNT 1 1 1 1
WIDTH 2
HEIGHT 1
VIEWPOINT 0 0 0 1 0 0 0
POINTS 2
DATA ascii
0 0 0 4278190080
1 2 3 4294901760
PCD
seed 01 ascii.ply <<'PLY'
ply
format ascii 1.0
element vertex 2
property float x
property float y
property float z
property float nx
property float ny
property float nz
element camera 1
property float32 view_px
property float32 focal
end_header
0 0 0 0 0 1
1 1 1 1 0 0
0 35
PLY
seed 02 points.xyz <<'XYZ'
# x y z nx ny nz
0 0 0 0 0 1
1 0 0 1 0 0
XYZ
# Binary PCD (plain and compressed), binary PLY and a depth PNG from the kit's own writers:
# pcl_* tools from pcl-tools are avoided on purpose (pcl_pcd2ply crashes on odd files).
if command -v python3 >/dev/null; then
  python3 - "$OUT/corpus" <<'PY'
import struct, sys, zlib
d = sys.argv[1]
hdr = ("VERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 3\nHEIGHT 1\n"
       "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\nDATA binary\n").encode()
pts = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0)
open(d + "/binary.pcd", "wb").write(b"\x00" + hdr + pts)
ply = (b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
       b"property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
       b"element face 1\nproperty list uchar int vertex_indices\nend_header\n")
body = b"".join(struct.pack("<3f3B", *p) for p in [(0, 0, 0, 255, 0, 0), (1, 0, 0, 0, 255, 0), (0, 1, 0, 0, 0, 255)])
body += struct.pack("<B3i", 3, 0, 1, 2)
open(d + "/binary.ply", "wb").write(b"\x01" + ply + body)
# 2 x 2 16-bit grey PNG
def chunk(t, b): return struct.pack(">I", len(b)) + t + b + struct.pack(">I", zlib.crc32(t + b) & 0xffffffff)
raw = b"".join(b"\x00" + struct.pack(">2H", 1000 + r, 0) for r in range(2))
png = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">2I5B", 2, 2, 16, 0, 0, 0, 0)) + \
      chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")
open(d + "/depth.png", "wb").write(b"\x03" + png)
PY
fi
# Regression inputs found earlier (real files, the format from the extension) seed it too.
for f in apps/common/test/regressions/*; do
  case "$f" in
    *.pcd) b=00 ;; *.ply) b=01 ;; *.xyz) b=02 ;; *.png) b=03 ;; *) continue ;;
  esac
  seed "$b" "regression_$(basename "$f")" < "$f"
done

echo "== fuzzing for ${SECONDS_TOTAL} s"
log=$OUT/fuzz.log
set +e
ASAN_OPTIONS=detect_leaks=1:allocator_may_return_null=1 "$bin" "$OUT/corpus" \
  -max_total_time="$SECONDS_TOTAL" -timeout=10 -rss_limit_mb=4096 -malloc_limit_mb=2048 -max_len=4096 \
  -artifact_prefix="$OUT/findings/" -print_final_stats=1 >"$log" 2>&1
rc=$?
set -e
grep -E "^#[0-9]+.*DONE|stat::number_of_executed_units|stat::peak_rss_mb" "$log" || tail -5 "$log"
findings=$(ls "$OUT/findings" 2>/dev/null | wc -l)
# Each finding as a real file for apps/common/test/regressions/ (format byte stripped).
for f in "$OUT"/findings/*; do
  [ -f "$f" ] || continue
  case "$f" in *.pcd|*.ply|*.xyz|*.png) continue ;; esac
  n=$(( $(head -c1 "$f" | od -An -tu1 | tr -d ' ') % 4 ))
  ext=(pcd ply xyz depth.png)
  tail -c +2 "$f" > "$f.${ext[$n]}"
  echo "finding: $f -> $f.${ext[$n]}"
done
echo "fuzz-loader: exit $rc, $findings finding(s) in $OUT/findings (log: $log)"
[ "$rc" -eq 0 ] && [ "$findings" -eq 0 ]
