#!/usr/bin/env bash
# Vendors the web page's one npm dependency, three.js, into www/vendor/ (issue 17).
#
# Runs `npm ci` on www/package.json + www/package-lock.json in a temporary copy
# (the lockfile pins the version and its sha512, so every run copies the same
# bytes) and copies three's ES-module build and its licence:
#   www/vendor/three.module.min.js   (imports ./three.core.min.js)
#   www/vendor/three.core.min.js
#   www/vendor/three.LICENSE
# The copied files are committed: building or running dfsmd never needs npm or
# the network, only this script does (after changing the version in
# www/package.json: run `npm install --package-lock-only` there first).
#
#   scripts/vendor-www.sh           copy into www/vendor/
#   scripts/vendor-www.sh --check   exit 1 when www/vendor/ differs from the lockfile's build
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
www="$here/../www"
check=false
[ "${1:-}" = "--check" ] && check=true

command -v npm >/dev/null || { echo "vendor-www: npm is not installed (apt-get install npm)" >&2; exit 1; }
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
cp "$www/package.json" "$www/package-lock.json" "$work/"
(cd "$work" && npm ci --ignore-scripts --no-audit --no-fund --loglevel=error >/dev/null)

three="$work/node_modules/three"
version="$(sed -n 's/^ *"version": *"\([^"]*\)".*/\1/p' "$three/package.json" | head -1)"
mkdir -p "$work/out"
cp "$three/build/three.module.min.js" "$three/build/three.core.min.js" "$work/out/"
cp "$three/LICENSE" "$work/out/three.LICENSE"
# The page imports only ./three.module.min.js; its one import must stay relative.
if grep -o 'from *"[^"]*"' "$work/out/three.module.min.js" | grep -v '"\./three\.core\.min\.js"' >/dev/null; then
  echo "vendor-www: three.module.min.js imports something other than ./three.core.min.js" >&2
  exit 1
fi

if $check; then
  status=0
  for f in three.module.min.js three.core.min.js three.LICENSE; do
    cmp -s "$work/out/$f" "$www/vendor/$f" || { echo "vendor-www: www/vendor/$f differs from three $version" >&2; status=1; }
  done
  [ $status -eq 0 ] && echo "vendor-www: www/vendor/ is three $version from the lockfile"
  exit $status
fi
mkdir -p "$www/vendor"
cp "$work/out/"* "$www/vendor/"
echo "vendor-www: three $version -> www/vendor/ ($(cd "$www/vendor" && ls | tr '\n' ' '))"
