#!/usr/bin/env bash
# Makes the regression baseline that tests/tools/regress_cli_test.cc compares
# every build against (docs/batch-and-regress.md):
#
#   tools/make_regress_baseline.sh                     # refresh tests/data/regress_baseline/run
#   tools/make_regress_baseline.sh --mcvo build-x/mcvo --out /tmp/candidate   # what the test does
#
# Recipe (the one place it is written down): `mcvo synth` renders 40 frames
# of the built-in stereo rig at 0.35 image scale with one sample per pixel
# (about 3 s), then `mcvo run` runs config/synthetic.json on it (about 1 s).
# Both run inside a scratch folder with relative paths, so run.json and the
# evaluation name the same paths on every machine.
#
# Only the deterministic outputs are kept: the run folder without
# timing.csv (DROP below; no images: the sequence is rendered again at test
# time).
#
# Idempotent: when a baseline is already there and `mcvo regress` finds the
# new run exactly equal to it (timing, version, command line and paths
# aside), the baseline is left untouched, so a refresh without a real change
# leaves `git status` clean.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/.." && pwd)
MCVO=$ROOT/build/mcvo
OUT=$ROOT/tests/data/regress_baseline/run
WORK=

usage() {
  echo "usage: $0 [--mcvo BIN] [--out DIR] [--work DIR]" >&2
  echo "  --mcvo BIN  the mcvo executable (default: build/mcvo)" >&2
  echo "  --out DIR   where the run folder goes (default: tests/data/regress_baseline/run)" >&2
  echo "  --work DIR  scratch folder for the sequence and the full run (default: a temporary one, removed)" >&2
  exit 2
}
while [ $# -gt 0 ]; do
  case "$1" in
    --mcvo) MCVO=$2; shift 2 ;;
    --out) OUT=$2; shift 2 ;;
    --work) WORK=$2; shift 2 ;;
    -h|--help) usage ;;
    *) echo "unknown argument: $1" >&2; usage ;;
  esac
done
[ -x "$MCVO" ] || { echo "$0: $MCVO is not an executable (build it, or pass --mcvo)" >&2; exit 2; }
MCVO=$(cd "$(dirname "$MCVO")" && pwd)/$(basename "$MCVO")
case "$OUT" in /*) ;; *) OUT=$PWD/$OUT ;; esac

if [ -z "$WORK" ]; then
  WORK=$(mktemp -d "${TMPDIR:-/tmp}/mcvo_regress_baseline.XXXXXX")
  trap 'rm -rf "$WORK"' EXIT
fi
mkdir -p "$WORK"
cd "$WORK"
rm -rf seq run
cp "$ROOT/config/synthetic.json" config.json
"$MCVO" synth --preset stereo --frames 40 --image-scale 0.35 --samples 1 --seed 0 --out seq
"$MCVO" run --dataset seq --config config.json --out run
# Outputs not kept: not deterministic, links into the scratch folder
# (colmap/images), or binary twins of kept text (colmap/sparse/0: the same
# model as colmap/sparse_txt/0, which is compared with tolerances). List a
# dropped output that run.json hashes in ignore_files of tolerances.json too.
DROP=(timing.csv colmap/images colmap/sparse/0)
for file in "${DROP[@]}"; do rm -rf "run/$file"; done

if [ -f "$OUT/run.json" ] && "$MCVO" regress --baseline "$OUT" --candidate run > regress.txt 2>&1; then
  echo "$0: $OUT is up to date (the new run is exactly equal); left untouched"
  exit 0
fi
mkdir -p "$(dirname "$OUT")"
rm -rf "$OUT.tmp"
cp -R run "$OUT.tmp"
rm -rf "$OUT"
mv "$OUT.tmp" "$OUT"
echo "$0: wrote $OUT ($(du -sk "$OUT" | cut -f1) KiB)"
