#!/usr/bin/env bash
# The test command (README, .ci/run): install, build, then every ctest suite on all cores.
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/build.sh"
ctest --test-dir "$ROOT/build" --output-on-failure -j "$(nproc)" --timeout 900 "$@"
