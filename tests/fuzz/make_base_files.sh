#!/usr/bin/env bash
# Regenerates tests/fuzz/base/*.h5, the small valid files the structure-aware fuzz targets mutate
# (docs/testing.md), by running the tool chain on a tiny synthetic series: a few dozen sand grains,
# two scans, and a few microseconds of fdemrun on a small model of their grains. Rerun it after a change of any file layout (the fuzz
# smoke test fails with "refused its unmutated base file" until then).
#   tests/fuzz/make_base_files.sh [BIN_DIR]      (default build/bin)
set -euo pipefail
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
BIN="$(cd "${1:-$ROOT/build/bin}" && pwd)"
OUT="$ROOT/tests/fuzz/base"
W="$(mktemp -d)"
trap 'rm -rf "$W"' EXIT
cd "$W"
run() { echo "+ $*" >&2; "$BIN/$1" "${@:2}" -q; }

cat > scene.toml <<'TOML'
seed = 5
grain-shape = "sand"
sh-degree = 8
d-min = "0.25mm"
d50 = "0.35mm"
d-max = "0.45mm"
diameter = "1.2mm"
height = "1.2mm"
solid-fraction = 0.45
contact-tolerance = 0.02
voxel-size = "40um"
strains = [0.0, 0.02]
band-width = "0.6mm"
TOML
run ctsynth scene.toml synth
for s in 0 1; do
  run ct2labels synth/scan_00$s.h5 labels_$s.h5 --config "$ROOT/pipelines/params/ct2labels.toml"
  run labels2shapes labels_$s.h5 synth/scan_00$s.h5 shapes_$s.h5 --degree 6
done
run labels2contacts labels_0.h5 synth/scan_000.h5 contacts.h5 --config "$ROOT/pipelines/params/labels2contacts.toml"
run shapes2tracks shapes_0.h5 shapes_1.h5 tracks.h5 --method paper
# A small model: 8 grains drawn from the scan's shapes, packed loosely; rigid grains settling under
# gravity for 3 us give frames with grain-grain contacts from frame 1 on.
run shapes2mesh shapes_0.h5 labels_0.h5 model.h5 --order 1 --surface-nodes 30 --packing equivalent --grains 8 \
    --solid-fraction 0.3
cat > settle.toml <<'TOML'
[run]
gravity = [0, 0, -9.81]
damping = 0
frame_interval = 1e-6
series_interval = 2e-7

[model]
kind = "rigid"

[[stages]]
name = "settle"
duration = 3e-6
TOML
run fdemrun settle.toml results.h5 --model model.h5
run tracks2micro results.h5 micro.h5
run fdem2forces results.h5 forces.h5 --from 1 --window 2

mkdir -p "$OUT"
cp synth/scan_000.h5 "$OUT/volume.h5"
cp synth/truth_000.h5 "$OUT/ground_truth.h5"
cp labels_0.h5 "$OUT/labels.h5"
cp shapes_0.h5 "$OUT/shapes.h5"
cp contacts.h5 tracks.h5 model.h5 results.h5 micro.h5 forces.h5 "$OUT/"
ls -l "$OUT"
