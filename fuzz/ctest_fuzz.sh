#!/bin/sh
# One short libFuzzer run for ctest:
#   ctest_fuzz.sh FUZZER SECONDS SCRATCH_DIR ARTIFACT_PREFIX DICT|- CORPUS_DIR...
# New inputs go to SCRATCH_DIR (listed first), so the committed corpora stay as
# they are. Corpus directories that do not exist (a harness with no
# regressions yet) are left out: libFuzzer would refuse them.
set -eu
fuzzer="$1" seconds="$2" scratch="$3" artifacts="$4" dict="$5"
shift 5
mkdir -p "$scratch" "$(dirname "$artifacts")"
set -- "$@" END
for dir in "$@"; do
  shift
  [ "$dir" = END ] && break
  [ -d "$dir" ] && set -- "$@" "$dir"
done
[ "$dict" = - ] || set -- -dict="$dict" "$@"
exec "$fuzzer" -max_total_time="$seconds" -print_final_stats=1 -timeout=10 -rss_limit_mb=2048 \
  -artifact_prefix="$artifacts" "$scratch" "$@"
