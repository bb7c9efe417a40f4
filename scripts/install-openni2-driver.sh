#!/usr/bin/env bash
# Installs the pclx virtual camera driver into OpenNI2's driver folder (as root; idempotent).
#   scripts/install-openni2-driver.sh <build dir | path to libPclxVirtualCamera.so.0>
# OpenNI.ini is not changed: the driver goes into the folder it already names.
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
name=libPclxVirtualCamera.so.0
arg=${1:-"$here/../build"}
if [ -d "$arg" ]; then
  so="$arg/drivers/openni2_virtual/$name"
else
  so="$arg"
fi
if [ ! -f "$so" ]; then
  echo "install-openni2-driver: $so not found; build it first (ninja -C <build> pclx_openni2_virtual)" >&2
  exit 1
fi
dir=$("$here/openni2-driver-dir.sh")
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
if [ -f "$dir/$name" ] && cmp -s "$so" "$dir/$name"; then
  echo "install-openni2-driver: $dir/$name is up to date"
  exit 0
fi
$SUDO install -d "$dir"
# Copy then rename: a process loading drivers never sees a half-written file.
$SUDO install -m 0644 "$so" "$dir/.$name.tmp"
$SUDO mv -f "$dir/.$name.tmp" "$dir/$name"
echo "install-openni2-driver: installed $dir/$name"
