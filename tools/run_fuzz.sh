#!/usr/bin/env bash
# Builds the libFuzzer targets (tests/fuzz/, docs/fuzzing.md) with clang into
# build-fuzz/ and runs each for FUZZ_SECONDS, one at a time, then writes
# results/fuzz.md and results/fuzz.csv (run by `make fuzz`).
#
#   tools/run_fuzz.sh [target ...]      default: every target
#
# Environment:
#   FUZZ_SECONDS   seconds per target (600)
#   FUZZ_BUILD     build folder (build-fuzz)
#   FUZZ_SCRATCH   where the working corpora, artifacts and logs go
#                  (a fresh mktemp folder); the seed corpus in
#                  tests/fuzz/corpus/ is copied there and never written
#   FUZZ_RESULTS   results file stem (results/fuzz -> .md and .csv); the
#                  .csv has one row per target: a run of some targets
#                  replaces their rows and keeps the others
#   FUZZ_NICE      niceness of the fuzzer processes (19)
#   JOBS           build parallelism (nproc)
#
# Exit status: 0 when every target ran its time without a crash, 1 otherwise
# (the reproducers are under FUZZ_SCRATCH/<target>/artifacts/).
set -euo pipefail
cd "$(dirname "$0")/.."

ALL_TARGETS=(rig_json config frames_csv trajectory kalibr kitti360_calib kitti360_mei track_file png_decode)
SECONDS_PER_TARGET=${FUZZ_SECONDS:-600}
BUILD=${FUZZ_BUILD:-build-fuzz}
RESULTS=${FUZZ_RESULTS:-results/fuzz}
NICE=${FUZZ_NICE:-19}
JOBS=${JOBS:-$(nproc 2>/dev/null || echo 2)}
SCRATCH=${FUZZ_SCRATCH:-$(mktemp -d "${TMPDIR:-/tmp}/mcvo-fuzz.XXXXXX")}
if [ $# -gt 0 ]; then TARGETS=("$@"); else TARGETS=("${ALL_TARGETS[@]}"); fi

for target in "${TARGETS[@]}"; do
  if [ ! -f "tests/fuzz/${target}_fuzz.cc" ]; then
    echo "run_fuzz.sh: unknown target '$target' (known: ${ALL_TARGETS[*]})" >&2
    exit 2
  fi
done
for tool in clang clang++ cmake; do
  command -v "$tool" >/dev/null || { echo "run_fuzz.sh: $tool not found (make deps installs it)" >&2; exit 2; }
done

# Debug: assertions (Eigen's bounds checks, MCVO_CHECK) stay on; the block
# at the end of CMakeLists.txt adds -O1 -g and the sanitizers. Warnings are
# not errors here: clang warns about other things than gcc.
if [ ! -f "$BUILD/CMakeCache.txt" ]; then
  CC=clang CXX=clang++ cmake -S . -B "$BUILD" -DCMAKE_BUILD_TYPE=Debug -DMCVO_FUZZ=ON \
    -DMCVO_BUILD_TESTS=OFF -DMCVO_WERROR=OFF
fi
# Only the targets to run (and the libraries they link).
BUILD_TARGETS=()
for target in "${TARGETS[@]}"; do BUILD_TARGETS+=("mcvo_fuzz_$target"); done
cmake --build "$BUILD" --target "${BUILD_TARGETS[@]}" -j "$JOBS"
# The checkout the targets were built from.
commit=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
if [ -n "$(git status --porcelain -- src include tests/fuzz CMakeLists.txt 2>/dev/null)" ]; then
  commit="$commit+uncommitted"
fi

mkdir -p "$SCRATCH" "$(dirname "$RESULTS")"
echo "== fuzzing ${#TARGETS[@]} target(s), ${SECONDS_PER_TARGET} s each; scratch: $SCRATCH"

# target,finished,seconds,executions,exec_per_s,seed_files,corpus_files,corpus_kb,cov,ft,peak_rss_mb,crashes,artifacts
ROWS=()
FAILED=0
for target in "${TARGETS[@]}"; do
  work="$SCRATCH/$target"
  rm -rf "$work"
  mkdir -p "$work/corpus" "$work/artifacts"
  cp tests/fuzz/corpus/"$target"/* "$work/corpus/"
  seeds=$(find "tests/fuzz/corpus/$target" -type f | wc -l)
  dict=()
  [ -f "tests/fuzz/$target.dict" ] && dict=(-dict="tests/fuzz/$target.dict")
  log="$work/fuzz.log"
  echo "-- $target (log: $log)"
  start=$(date +%s)
  set +e
  # One process (no -jobs/-fork): a crash ends the run and is reported.
  # -timeout: an input slower than 10 s is a hang (a crash too).
  # The outer timeout is a guard only; libFuzzer stops at max_total_time.
  TMPDIR="$work" timeout $((SECONDS_PER_TARGET + 300)) nice -n "$NICE" "$BUILD/mcvo_fuzz_$target" \
    "${dict[@]}" -max_total_time="$SECONDS_PER_TARGET" -timeout=10 -rss_limit_mb=2048 \
    -print_final_stats=1 -artifact_prefix="$work/artifacts/" "$work/corpus" >"$log" 2>&1
  status=$?
  set -e
  elapsed=$(($(date +%s) - start))
  finished=$(date -u +%Y-%m-%dT%H:%MZ)
  final_stat() { sed -n "s/^stat::$1: *//p" "$log" | tail -1; }
  executions=$(final_stat number_of_executed_units)
  exec_per_s=$(final_stat average_exec_per_sec)
  peak_rss=$(final_stat peak_rss_mb)
  final=$(grep -E '^#[0-9]+' "$log" | tail -1 || true)
  cov=$(sed -n 's/.* cov: \([0-9]*\).*/\1/p' <<<"$final")
  ft=$(sed -n 's/.* ft: \([0-9]*\).*/\1/p' <<<"$final")
  corpus_files=$(find "$work/corpus" -type f | wc -l)
  corpus_kb=$(find "$work/corpus" -type f -printf '%s\n' | awk '{ s += $1 } END { printf "%d", (s + 1023) / 1024 }')
  artifacts=$(find "$work/artifacts" -type f | wc -l)
  crashes=$artifacts
  if [ "$status" -ne 0 ] && [ "$artifacts" -eq 0 ]; then crashes=1; fi
  if [ "$crashes" -gt 0 ]; then FAILED=1; fi
  artifact_names=$(find "$work/artifacts" -type f -printf '%f ' | sed 's/ $//')
  echo "   ${elapsed} s, ${executions:-?} executions, ${exec_per_s:-?} exec/s, cov ${cov:-?}, ft ${ft:-?}," \
    "corpus ${corpus_files} files, crashes ${crashes}${artifact_names:+ ($artifact_names)}"
  ROWS+=("$target,$finished,$elapsed,${executions:-0},${exec_per_s:-0},$seeds,$corpus_files,$corpus_kb,${cov:-0},${ft:-0},${peak_rss:-0},$crashes,$artifact_names")
done

# ---- results: results/fuzz.csv holds one row per target; a run of some
# targets replaces their rows and keeps the others (each row has its date).
cpu=$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1)
clang_version=$(clang++ --version | head -1)
HEADER="target,finished,commit,seconds,executions,exec_per_s,seed_files,corpus_files,corpus_kb,cov,ft,peak_rss_mb,crashes,artifacts"

declare -A ROW_OF
if [ -f "$RESULTS.csv" ] && [ "$(head -1 "$RESULTS.csv")" = "$HEADER" ]; then
  while IFS= read -r line; do ROW_OF[${line%%,*}]=$line; done < <(tail -n +2 "$RESULTS.csv")
fi
for row in "${ROWS[@]}"; do
  IFS=, read -r target finished rest <<<"$row"
  ROW_OF[$target]="$target,$finished,$commit,$rest"
done
{
  echo "$HEADER"
  for target in "${ALL_TARGETS[@]}"; do
    if [ -n "${ROW_OF[$target]:-}" ]; then echo "${ROW_OF[$target]}"; fi
  done
} >"$RESULTS.csv"

{
  echo "# Fuzzing the input readers"
  echo
  echo "libFuzzer with ASan and UBSan, one target per reader (docs/fuzzing.md);"
  echo "written by \`make fuzz\` (tools/run_fuzz.sh), numbers in fuzz.csv."
  echo
  echo "- machine: $(nproc) cores, ${cpu:-unknown CPU}; $clang_version"
  echo "- each target alone, one process under \`nice -n $NICE\`, \`-timeout=10 -rss_limit_mb=2048\`,"
  echo "  from its seed corpus tests/fuzz/corpus/<target>/ (copied) with tests/fuzz/<target>.dict where there is one"
  echo "- build: clang, \`-fsanitize=fuzzer,address,undefined -fno-sanitize-recover=all -g -O1\`,"
  echo "  assertions on (CMAKE_BUILD_TYPE=Debug), every mcvo library instrumented"
  echo "- commit: the checkout the targets were built from (+uncommitted: with changes not yet committed)"
  echo
  echo "| target | reader | finished (UTC) | commit | seconds | executions | exec/s | corpus: seeds -> end | cov | ft | peak RSS MB | crashes |"
  echo "|---|---|---|---|---:|---:|---:|---|---:|---:|---:|---:|"
  tail -n +2 "$RESULTS.csv" | while IFS=, read -r t date rev secs execs eps seeds files kb cov ft rss crashes names; do
    case "$t" in
      rig_json) reader="rig.json (ParseRigJson)" ;;
      config) reader="pipeline config (ParsePipelineOptions)" ;;
      frames_csv) reader="frames.csv (ParseFrameTable)" ;;
      trajectory) reader="TUM / KITTI / KITTI-indexed / EuRoC (ParseTrajectory)" ;;
      kalibr) reader="Kalibr camchain.yaml (ReadKalibrDataset)" ;;
      kitti360_calib) reader="KITTI-360 calib_cam_to_pose.txt, perspective.txt, timestamps.txt" ;;
      kitti360_mei) reader="KITTI-360 image_0N.yaml (ReadMeiYaml)" ;;
      track_file) reader="track file (TrackFileReader)" ;;
      png_decode) reader="PNG images (DecodePng, against OpenCV)" ;;
      *) reader="" ;;
    esac
    echo "| $t | $reader | $date | $rev | $secs | $execs | $eps | $seeds -> $files files, $kb KB | $cov | $ft | $rss | $crashes${names:+ ($names)} |"
  done
  echo
  echo "cov: coverage points (edges) reached and ft: libFuzzer features, from the last"
  echo "status line; exec/s: libFuzzer's average over the run; crashes: inputs that broke"
  echo "the contract (crash, sanitizer finding, hang, out of memory)."
  if [ -f tests/fuzz/findings.md ]; then
    echo
    cat tests/fuzz/findings.md
  fi
} >"$RESULTS.md"

echo "== wrote $RESULTS.md and $RESULTS.csv"
exit "$FAILED"
