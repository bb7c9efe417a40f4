#!/usr/bin/env bash
# Prints the folder OpenNI2 loads drivers from: [Drivers] Repository in /etc/openni2/OpenNI.ini
# (Debian's location), else OpenNI2/Drivers, relative to the folder of libOpenNI2.so.0.
set -euo pipefail
lib=$(ldconfig -p | awk '$1 == "libOpenNI2.so.0" { print $NF; exit }')
if [ -z "$lib" ]; then
  echo "openni2-driver-dir: libOpenNI2.so.0 not found (install libopenni2-0)" >&2
  exit 1
fi
base=$(dirname "$(readlink -f "$lib")")
repo=""
ini=/etc/openni2/OpenNI.ini
if [ -f "$ini" ]; then
  repo=$(awk -F= '
    /^[[:space:]]*\[/ { section = $0; gsub(/[[:space:]\[\]]/, "", section); next }
    section == "Drivers" && $1 ~ /^[[:space:]]*Repository[[:space:]]*$/ {
      v = $2; gsub(/^[[:space:]"]+|[[:space:]"]+$/, "", v); print v; exit }' "$ini")
fi
[ -n "$repo" ] || repo="OpenNI2/Drivers"
case "$repo" in
  /*) echo "$repo" ;;
  *) echo "$base/$repo" ;;
esac
