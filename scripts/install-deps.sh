#!/usr/bin/env bash
# Installs the Debian bookworm packages pclx needs; does nothing when all are present.
# Runs as root (CI and fresh machines) or through sudo when available.
set -euo pipefail
PKGS=(
  build-essential cmake ninja-build ccache pkg-config git
  libpcl-dev pcl-tools libeigen3-dev libflann-dev liblz4-dev libqhull-dev libboost-all-dev
  libvtk9-dev libopenni2-dev libpng-dev
  libembree-dev libcgal-dev libtbb-dev
  libgtest-dev libgmock-dev libbenchmark-dev libcli11-dev
  libopen3d-dev nlohmann-json3-dev
  xvfb xauth gnuplot-nox python3-matplotlib python3-numpy time
  chromium nodejs doxygen
)
# npm ships inside NodeSource's nodejs; Debian's nodejs needs its npm package.
command -v npm > /dev/null 2>&1 || PKGS+=(npm)
missing=()
for p in "${PKGS[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#PKGS[@]} packages present"
  exit 0
fi
echo "install-deps: installing ${missing[*]}"
SUDO=""
[ "$(id -u)" -ne 0 ] && SUDO="sudo"
$SUDO apt-get update
DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y --no-install-recommends "${missing[@]}"
