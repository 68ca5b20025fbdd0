#!/usr/bin/env bash
# The pipeline's stage graph (Makefile.pipeline, dry run): a one-scan series is meshed, simulated,
# its forces analysed and reported; only track and micro wait for a second scan; validate runs only
# on a series with ctsynth's ground truth.
#   pipeline_stages.sh SOURCE_DIR BIN_DIR
set -euo pipefail
src=$1 bin=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$tmp/one" "$tmp/two" "$tmp/truth"
touch "$tmp/one/scan_000.h5" "$tmp/two/scan_000.h5" "$tmp/two/scan_001.h5"
touch "$tmp/truth/scan_000.h5" "$tmp/truth/scan_001.h5" "$tmp/truth/truth_000.h5" "$tmp/truth/truth_001.h5"
dry() { make -C "$src" -f Makefile.pipeline -n -B SERIES="$1" IN="$tmp/$1" OUT="$tmp/runs/$1" BIN="$bin"; }
status=0
expect() {  # expect SERIES yes|no TOOL
  local runs=no
  grep -q "$bin/$3 " <<<"$commands" && runs=yes
  if [ "$runs" != "$2" ]; then
    echo "series '$1': $3 runs=$runs, expected $2" >&2
    status=1
  fi
}
commands=$(dry one)
for tool in ct2labels labels2contacts labels2shapes shapes2mesh fdemrun fdem2forces tracks2micro report; do expect one yes "$tool"; done
expect one no shapes2tracks
expect one no validate
commands=$(dry two)
for tool in shapes2tracks tracks2micro fdemrun fdem2forces report; do expect two yes "$tool"; done
expect two no validate
commands=$(dry truth)
for tool in shapes2tracks tracks2micro fdemrun validate report; do expect truth yes "$tool"; done
exit $status
