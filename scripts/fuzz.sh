#!/usr/bin/env bash
# Fuzz campaigns over every parser: builds the libFuzzer harnesses of fuzz/ with AddressSanitizer
# and UndefinedBehaviorSanitizer (clang 14, CMake option ODYSSEY_FUZZ) in build-fuzz/, seeds a
# corpus per harness from the shared assets, data/ and small generated files, then runs the
# harnesses one after the other and prints a table. Exits non-zero when any harness has a
# finding (a crash, sanitizer report, leak, timeout, out-of-memory, or a parser exception other
# than InputError / std::invalid_argument); the input is saved under build-fuzz/fuzz-findings/.
#
#   scripts/fuzz.sh [SECONDS_PER_HARNESS] [RUNS_PER_HARNESS]
#     SECONDS_PER_HARNESS   -max_total_time of each harness (default 30, the CI-sized run; 0: no limit)
#     RUNS_PER_HARNESS      -runs of each harness (default -1: no limit); a harness stops at
#                           whichever limit comes first
#   ODYSSEY_FUZZ_HARNESSES  space-separated subset to run (default: all thirteen)
#   ODYSSEY_FUZZ_BUILD_JOBS parallel compile jobs (default: nproc)
#   ODYSSEY_SHARED_DIR      the shared folder (default: ../shared beside the checkout)
#   ODYSSEY_FUZZ_NO_BUILD=1 run the harnesses already in build-fuzz/ (no configure, no build)
#   ODYSSEY_FUZZ_SEED       libFuzzer's -seed (default 0: random); with a RUNS limit and a fresh
#                           corpus a fixed seed makes the run repeatable, as CI runs it
#
# The corpora live in build-fuzz/fuzz-corpus/<harness> and grow from run to run; the shared
# folder is only ever read. Reproduce a finding with build-fuzz/fuzz/fuzz_<harness> FILE.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
shared=${ODYSSEY_SHARED_DIR:-$(dirname "$0")/../../shared}
seconds=${1:-30}
runs=${2:--1}
harnesses=(${ODYSSEY_FUZZ_HARNESSES:-npy npz body_model amass bvh gltf bone_map camera_path obj scene anime camera_import manifest})
build="$root/build-fuzz"

# clang 14 and its runtime libraries (libFuzzer, the sanitizers), as scripts/install-deps.sh
# installs packages: as root or through sudo.
if ! command -v clang++-14 >/dev/null 2>&1 || ! dpkg -s libclang-rt-14-dev >/dev/null 2>&1; then
  as_root=()
  [ "$(id -u)" -eq 0 ] || as_root=(sudo)
  "${as_root[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${as_root[@]}" apt-get install -y -qq --no-install-recommends clang-14 libclang-rt-14-dev >/dev/null
fi

if [ "${ODYSSEY_FUZZ_NO_BUILD:-0}" != 1 ]; then
  CC=clang-14 CXX=clang++-14 cmake -S "$root" -B "$build" -DODYSSEY_FUZZ=ON -DODYSSEY_BUILD_TESTS=OFF \
    -DODYSSEY_BUILD_BENCH=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo >"$build.configure.log" 2>&1 ||
    { cat "$build.configure.log"; exit 1; }
  targets=(fuzz_make_seeds "${harnesses[@]/#/fuzz_}")
  cmake --build "$build" --target "${targets[@]}" -j "${ODYSSEY_FUZZ_BUILD_JOBS:-$(nproc)}"
fi

# Seeds: copied (never linked) into the scratch corpora, so nothing under $shared is written.
generated="$build/fuzz-seeds"
rm -rf "$generated"
"$build/fuzz/fuzz_make_seeds" "$generated"
corpus_root="$build/fuzz-corpus"
seed() {  # seed HARNESS FILE...: copies the files that exist and are at most 256 KB
  local dir="$corpus_root/$1" file
  shift
  mkdir -p "$dir"
  for file in "$@"; do
    if [ -f "$file" ] && [ "$(stat -c %s "$file")" -le 262144 ]; then
      install -m 644 "$file" "$dir/seed-$(basename "$file")"
    fi
  done
}
# BVH seeds: each file's hierarchy and its first three frames (the whole files are up to 2 MB).
bvh_seed() {
  local dir="$corpus_root/bvh" file
  mkdir -p "$dir"
  for file in "$@"; do
    [ -f "$file" ] || continue
    awk 'motion && /^Frames:/ { print "Frames: 3"; next }
         motion && /^Frame Time:/ { print; frames = 1; next }
         frames { if (++n > 3) exit }
         { print }
         /^MOTION/ { motion = 1 }' "$file" >"$dir/seed-$(basename "$file")"
  done
}
seed npy "$generated"/npy/*
seed npz "$generated"/npz/*
seed body_model "$generated"/body_model/*
seed amass "$generated"/amass/*
bvh_seed "$shared"/assets/mocap/*.bvh "$root"/data/mocap/*.bvh
seed gltf "$shared"/assets/characters/*.gl* "$shared"/assets/characters/*/*.gltf "$shared"/assets/animations/*.gl* \
  "$root"/data/characters/*.gl*
seed bone_map "$root"/retarget/presets/*.json
seed camera_path "$generated"/camera_path/*
seed obj "$generated"/obj/*
seed scene "$root"/data/scenes/*.json
seed anime "$generated"/anime/*
seed camera_import "$generated"/camera_import/*
seed manifest "$generated"/manifest/*

failed=0
rows=()
for harness in "${harnesses[@]}"; do
  binary="$build/fuzz/fuzz_$harness"
  findings_dir="$build/fuzz-findings/$harness"
  log="$build/fuzz-logs/$harness.log"
  mkdir -p "$findings_dir" "$(dirname "$log")" "$corpus_root/$harness"
  before=$(find "$findings_dir" -type f | wc -l)
  start=$(date +%s.%N)
  set +e
  UBSAN_OPTIONS=${UBSAN_OPTIONS:-print_stacktrace=1} "$binary" "$corpus_root/$harness" \
    -max_total_time="$seconds" -runs="$runs" -seed="${ODYSSEY_FUZZ_SEED:-0}" -rss_limit_mb=2048 -timeout=10 -print_final_stats=1 \
    -artifact_prefix="$findings_dir/" >"$log" 2>&1
  rc=$?
  set -e
  end=$(date +%s.%N)
  executions=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -1)
  executions=${executions:-0}
  findings=$(($(find "$findings_dir" -type f | wc -l) - before))
  if [ "$rc" -ne 0 ] && [ "$findings" -eq 0 ]; then findings=1; fi
  if [ "$findings" -ne 0 ]; then
    failed=1
    echo "=== fuzz_$harness: finding (exit $rc), log $log" >&2
    grep -E "ERROR|SUMMARY|runtime error|odyssey fuzz:|Test unit written" "$log" | head -20 >&2 || true
  fi
  rows+=("$(awk -v h="$harness" -v e="$executions" -v s="$start" -v t="$end" -v f="$findings" \
    'BEGIN { d = t - s; printf "%-12s %12d %9.1f %9.0f %9d", h, e, d, (d > 0 ? e / d : 0), f }')")
done

printf '%-12s %12s %9s %9s %9s\n' harness executions seconds exec/s findings
printf '%s\n' "${rows[@]}"
exit "$failed"
