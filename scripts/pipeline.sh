#!/usr/bin/env bash
# The main job (README): install, build, then run Makefile.pipeline on the bundled sample series
# (SERIES=... picks another folder of sample_volumes/; extra arguments go to make, e.g. a stage name).
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
bash "$ROOT/scripts/build.sh"
cd "$ROOT"
make -f Makefile.pipeline -j "$(nproc)" "$@"
