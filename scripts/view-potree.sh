#!/usr/bin/env bash
# Opens a Potree 2.0 folder (omicron_viewer --output, or a budgeted build's folder) in a local
# page with potree-core: serves it on 127.0.0.1 and prints the address (and opens it in
# Chromium when there is a display). potree-core and three come from npm, installed once into
# ~/.cache/pclx/potree-npm.
#   scripts/view-potree.sh DIR [PORT]
set -euo pipefail
[ $# -ge 1 ] && [ -f "$1/metadata.json" ] || { echo "usage: $0 POTREE_DIR [PORT]  (a folder with metadata.json)" >&2; exit 2; }
here="$(cd "$(dirname "$0")/.." && pwd)"
folder="$(cd "$1" && pwd)"
npm_dir="${XDG_CACHE_HOME:-$HOME/.cache}/pclx/potree-npm"
if [ ! -f "$npm_dir/node_modules/potree-core/dist/index.js" ]; then
  mkdir -p "$npm_dir"
  npm install --prefix "$npm_dir" --no-audit --no-fund --loglevel=error potree-core@2.0.15 three@0.187.0
fi
site="$(mktemp -d)"
trap 'rm -rf "$site"' EXIT
ln -s "$npm_dir/node_modules" "$site/node_modules"
ln -s "$folder" "$site/cloud"
cp "$here/apps/omicron_viewer/potree_page/view.html" "$here/apps/omicron_viewer/potree_page/fill_colour.js" "$site/"
exec 3< <(node "$here/apps/omicron_viewer/potree_page/server.js" "$site" "${2:-0}")
read -r port <&3
url="http://127.0.0.1:$port/view.html?cloud=/cloud"
echo "view-potree: $folder at $url (Ctrl-C stops the server)"
if [ -n "${DISPLAY:-}" ] && command -v chromium > /dev/null; then
  chromium "$url" > /dev/null 2>&1 &
fi
wait
