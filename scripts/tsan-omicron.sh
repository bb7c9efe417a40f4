#!/usr/bin/env bash
# ThreadSanitizer run of the OMiCroN module: builds libpclx_omicron and test_omicron (nothing
# else) with -fsanitize=thread in build-tsan/ and runs the tests; any report fails the run.
# The module uses only std::thread, mutexes and atomics (no TBB: Debian's libtbb is not
# instrumented, so its task handoffs would be reported as races).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=$(realpath -m "${PCLX_TSAN_BUILD_DIR:-build-tsan}")
JOBS=$(nproc)
cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_FLAGS="-fsanitize=thread -fno-omit-frame-pointer" \
  -DCMAKE_EXE_LINKER_FLAGS="-fsanitize=thread" -DCMAKE_SHARED_LINKER_FLAGS="-fsanitize=thread" \
  -DPCLX_BUILD_APPS=OFF -DPCLX_BUILD_BENCH=OFF -DPCLX_BUILD_DRIVERS=OFF >/dev/null
# pcl_io (used for LZF-compressed PCD) loads Debian's libOpenNI2, whose own mutex handling at
# exit is reported (not instrumented, not ours): calls from that library are suppressed.
printf 'called_from_lib:libOpenNI2.so.0\n' >"$BUILD/tsan.supp"
# halt_on_error: the first report fails the run (also during gtest's test discovery at build
# time); second_deadlock_stack for lock-order reports.
export TSAN_OPTIONS="halt_on_error=1 second_deadlock_stack=1 suppressions=$BUILD/tsan.supp ${TSAN_OPTIONS:-}"
cmake --build "$BUILD" -j "$JOBS" --target test_omicron
# The 2M-point end-to-end test runs the same threads as the other octree tests on more data
# (30 s under TSan): left to the release and ASan runs to keep this one short.
"$BUILD/test/omicron/test_omicron" --gtest_brief=1 --gtest_filter=-*MillionsOfDuplicates*
echo "tsan-omicron.sh: test_omicron passed under ThreadSanitizer"
