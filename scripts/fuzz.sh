#!/usr/bin/env bash
# Fuzzes every file reader (tests/fuzz, docs/testing.md): builds the libFuzzer programs with clang,
# AddressSanitizer and UndefinedBehaviorSanitizer in build-fuzz/, then runs each target for a fixed
# budget, starting from its stored corpus (tests/fuzz/corpus/<target>) and regression inputs.
#   scripts/fuzz.sh [SECONDS_PER_TARGET] [TARGET...]     (default 60 s, every target)
# Exits non-zero on any finding; the input that caused it is kept as
# build-fuzz/findings/<target>/crash-* (or leak-*, oom-*, timeout-*), and the line to rerun it is
# printed. New inputs that reach more code go to build-fuzz/corpus/<target>, not into the repository.
set -euo pipefail
launcher=()
command -v ccache >/dev/null && launcher=(-DCMAKE_CXX_COMPILER_LAUNCHER=ccache -DCMAKE_C_COMPILER_LAUNCHER=ccache)
ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
SECONDS_PER_TARGET="${1:-60}"
shift || true
BUILD="$ROOT/build-fuzz"

# clang and libFuzzer (in libclang-rt-14-dev), with the project's own packages. FUZZ_SKIP_BUILD=1
# fuzzes with the programs already in build-fuzz/bin.
if [ "${FUZZ_SKIP_BUILD:-0}" != 1 ]; then
  bash "$ROOT/scripts/deps.sh" clang-14 libclang-rt-14-dev
  cmake -S "$ROOT" -B "$BUILD" -G Ninja "${launcher[@]}" -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g1" \
    -DCMAKE_C_COMPILER=clang-14 -DCMAKE_CXX_COMPILER=clang++-14 \
    -DGRAINTWIN_FUZZ=ON -DGRAINTWIN_BUILD_TESTS=OFF -DGRAINTWIN_BUILD_BENCH=OFF >/dev/null
  cmake --build "$BUILD" -j "$(nproc)" --target fuzz_targets
fi

if (($# > 0)); then targets=("$@"); else
  mapfile -t targets < <(cd "$BUILD/bin" && ls -- *_fuzz | sed 's/_fuzz$//')
fi
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:allocator_may_return_null=0"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"
failed=()
for t in "${targets[@]}"; do
  work="$BUILD/corpus/$t"
  found="$BUILD/findings/$t"
  mkdir -p "$work" "$found"
  seeds=("$ROOT/tests/fuzz/corpus/$t")
  [ -d "$ROOT/tests/fuzz/regression/$t" ] && seeds+=("$ROOT/tests/fuzz/regression/$t")
  echo "fuzz: $t for ${SECONDS_PER_TARGET} s"
  # -rss_limit_mb/-malloc_limit_mb: a reader that asks for more than 2 GB on inputs of at most 4 KB
  # is a finding (a size taken from the file and not checked against it).
  if ! (cd "$found" && "$BUILD/bin/${t}_fuzz" "$work" "${seeds[@]}" -max_total_time="$SECONDS_PER_TARGET" \
          -max_len=4096 -timeout=20 -rss_limit_mb=2560 -malloc_limit_mb=2048 -print_final_stats=1 \
          >"$BUILD/findings/$t.log" 2>&1); then
    failed+=("$t")
    echo "fuzz: FINDING in $t; log $BUILD/findings/$t.log, inputs:" >&2
    ls -1 "$found" | sed "s|^|  $found/|" >&2
    echo "  rerun: $BUILD/bin/${t}_fuzz <input>   (the normal build: build/bin/graintwin_fuzz_replay $t <input>)" >&2
  else
    grep -E "stat::number_of_executed_units|cov:" "$BUILD/findings/$t.log" | tail -2 | sed 's/^/  /'
  fi
done
if ((${#failed[@]})); then
  echo "fuzz: findings in ${failed[*]}" >&2
  exit 1
fi
echo "fuzz: ${#targets[@]} targets ran ${SECONDS_PER_TARGET} s each without a finding"
