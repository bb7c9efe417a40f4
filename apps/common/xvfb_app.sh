#!/usr/bin/env bash
# `xvfb-run -a` for the app checks, exiting with the command's own status: xvfb-run itself
# exits 5 when it cannot remove its temporary directory, which happened once in CI after the
# app had exited correctly, and that is not the app's result.
#   xvfb_app.sh [-a] <command> [args...]
set -u
[ "${1:-}" = "-a" ] && shift
xvfb=$(command -v xvfb-run) || { echo "xvfb_app.sh: xvfb-run not found" >&2; exit 127; }
status=$(mktemp) || exit 1
"$xvfb" -a sh -c '"$@"; echo $? > "$0"' "$status" "$@"
xrc=$?
rc=$(cat "$status" 2>/dev/null)
rm -f "$status"
if [ -z "$rc" ]; then
  echo "xvfb_app.sh: xvfb-run exited $xrc before the command finished" >&2
  exit $(( xrc == 0 ? 1 : xrc ))
fi
exit "$rc"
