#!/usr/bin/env bash
# The architecture rules of the tree, checked from the #include lines:
#  1. api/ and daemon/service/ never include daemon/capture/ (the service sees
#     the camera through its port; dfsmd/ plugs capture in behind it), and
#     daemon/capture/ never includes daemon/service/ (capture knows nothing of
#     jobs or the daemon's configuration);
#  2. nothing outside tests/ includes tests/, but for tests/support/ (code only
#     tests and benchmarks use: simulated tracks, the calibration sweep), which
#     the tests beside the code (*_test.cc) and bench/ may include;
#  3. no cycle between folders (core/<area>, daemon/<part>, and the top-level
#     folders), found by tsort. Tests beside the code (*_test.cc, *_test_*)
#     are leaves that may use a higher layer (core/dense's accuracy test scores
#     with core/pipeline's evaluation), so they make no edges;
#  4. only tests and benchmarks include OpenCV's imgcodecs: it loads ~140
#     shared libraries (~100 ms of start-up) into whatever links it, and the
#     product reads and writes images through core/io (libpng, TurboJPEG,
#     libtiff). CMakeLists.txt does not link it either.
# Prints each violation and exits 1 if there is any.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

folder() {  # core/io/burst.h -> core/io; api/routes.h -> api
  case "$1" in
    core/* | daemon/* | tests/support/*) echo "$1" | cut -d/ -f1-2 ;;
    *) echo "$1" | cut -d/ -f1 ;;
  esac
}

status=0
edges=$(mktemp)
trap 'rm -f "$edges"' EXIT
while IFS= read -r source; do
  from="$(folder "$source")"
  while IFS= read -r included; do
    [ -e "$included" ] || continue  # a system header
    to="$(folder "$included")"
    case "$from:$to" in
      api:daemon/capture | daemon/service:daemon/capture)
        echo "architecture: $source includes $included (capture is behind the camera port)"
        status=1 ;;
      daemon/capture:daemon/service)
        echo "architecture: $source includes $included (capture does not know the service)"
        status=1 ;;
    esac
    case "$from:$to:$source" in
      tests*:tests*:* | bench:tests/support:* | *:tests/support:*_test.cc | *:tests/support:*_test_*) ;;
      *:tests:* | *:tests/support:*)
        echo "architecture: $source includes $included (only tests/, and tests and" \
          "benchmarks of tests/support/, may depend on tests/)"
        status=1 ;;
    esac
    case "$source" in *_test.cc | *_test_*) continue ;; esac
    [ "$from" != "$to" ] && echo "$from $to" >>"$edges"
  done < <(sed -n 's/^#include "\([^"]*\)".*/\1/p' "$source")
done < <(git ls-files '*.cc' '*.h')

while IFS= read -r source; do
  case "$source" in *_test.cc | *_test_* | tests/* | bench/*) continue ;; esac
  if grep -q '^#include <opencv2/imgcodecs' "$source"; then
    echo "architecture: $source includes opencv2/imgcodecs (images go through core/io)"
    status=1
  fi
done < <(git ls-files '*.cc' '*.h')

if ! sort -u "$edges" | tsort >/dev/null 2>"$edges.err"; then
  echo "architecture: the folders depend on each other in a cycle:"
  sed 's/^/  /' "$edges.err"
  status=1
fi
rm -f "$edges.err"
[ "$status" = 0 ] && echo "architecture: ok ($(sort -u "$edges" | wc -l) folder dependencies, no cycle)"
exit "$status"
