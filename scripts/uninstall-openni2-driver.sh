#!/usr/bin/env bash
# Removes the pclx virtual camera driver from OpenNI2's driver folder (idempotent).
set -euo pipefail
here=$(cd "$(dirname "$0")" && pwd)
dir=$("$here/openni2-driver-dir.sh")
name=libPclxVirtualCamera.so.0
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
if [ -e "$dir/$name" ]; then
  $SUDO rm -f "$dir/$name"
  echo "uninstall-openni2-driver: removed $dir/$name"
else
  echo "uninstall-openni2-driver: $dir/$name is not installed"
fi
