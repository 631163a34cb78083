#!/usr/bin/env bash
# The anchor check of the LK tracker (frontend.anchor, patch_aligner.h)
# against LK alone, on rendered sequences where every pixel's truth is
# known. Per sequence and rig config:
#   1. `mcvo track` with frontend.anchor.enabled true and false;
#   2. mcvo_bench_track_truth on each: the tracked pixels' error against the
#      renderer's projection of the point each feature was detected on, per
#      camera and track length, and a third track file with those true
#      pixels (cross-camera matches too);
#   3. `mcvo run --tracks` on the three track files: ATE and scale error of
#      the same pipeline on LK alone, on the anchored tracks, and on the
#      true pixels of the LK features (what tracking error costs); on rigs
#      with cross-camera matches also on the anchored tracks with only the
#      matches made perfect (mcvo_bench_track_truth ... matches: what the
#      matching errors alone cost).
# Writes results/anchor_tracking.md (also printed).
#
#   tools/bench_anchor.sh [BUILD_DIR]     BUILD_DIR defaults to build
#   env FRAMES   frames per sequence (default 150)
#   env CACHE    render cache (default /tmp/mcvo_anchor_bench); renders are
#                kept and reused for the same arguments
# About 6 minutes on 2 cores with the renders, 3 without.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build}
FRAMES=${FRAMES:-150}
CACHE=${CACHE:-/tmp/mcvo_anchor_bench}
MCVO=$BUILD/mcvo
BENCH=$BUILD/mcvo_bench_track_truth
for exe in "$MCVO" "$BENCH"; do
  [[ -x "$exe" ]] || { echo "bench_anchor.sh: $exe not built (make build)" >&2; exit 2; }
done
mkdir -p "$CACHE" results
OUT=results/anchor_tracking.md
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT

# name | mcvo synth arguments | config
SEQUENCES=(
  "k3_block_s11|--preset kitti360-3cam --scene urban_block --seed 11 --image-scale 0.5|kitti360_3cam"
  "k360_urban_s1|--preset kitti360 --scene urban --seed 1 --image-scale 0.5|kitti360_4cam"
  "mc6_urban_s33_vign|--preset multicam6 --scene urban --seed 33 --image-scale 0.45 --vignetting|multicam6"
)

# `mcvo run --tracks` summary line: ATE % of path, signed scale error %.
run_summary() {  # dataset tracks config out
  "$MCVO" run --dataset "$1" --tracks "$2" --config "$3" --out "$4" --force --threads 2 > "$4.log" 2>&1
  python3 - "$4" <<'PY'
import json, sys
d = sys.argv[1]
r = json.load(open(d + "/run.json"))["result"]
s = json.load(open(d + "/eval/eval.json"))["scale"]
print("%d | %.3f | %+.3f |" % (r["posed_frames"], r["ate_percent_of_path"], s["scale_error_signed_percent"]))
PY
}

{
  echo "# Anchor check of LK tracks: accuracy against the renderer's truth"
  echo
  echo "Written by \`tools/bench_anchor.sh\` ($FRAMES frames per sequence, commit $(git rev-parse --short HEAD 2>/dev/null || echo unknown))."
  echo "Tracking error: the tracked pixel against the projection of the 3-D point the feature was"
  echo "detected on (static scene only), by track length (frames since detection, detection = 1);"
  echo "\"along motion\": the error's component along the feature's image motion since detection"
  echo "(positive: ahead of the truth). Cross-camera matches (rigs with overlapping views): the matched"
  echo "pixel in camera b against where b sees the point camera a's ray hits at a's tracked pixel, and the"
  echo "signed error of the depth the match triangulates (the metric scale it lends the back end)."
  echo "Runs: \`mcvo run --tracks\` with the rig's config on the LK-only tracks, the anchored tracks,"
  echo "the LK-only features (and their cross-camera matches) moved to their true pixels, and, on rigs with"
  echo "cross-camera matches, the anchored tracks as tracked with every match moved to where camera b sees"
  echo "the point a's tracked pixel sees (perfect matching: what the matching errors alone cost)."
  echo "The second cross-camera table: the relative error of the inverse depth a match triangulates, by the"
  echo "point's true depth, median and mean over the 5-95 % quantiles (a bias of a few hundredths of a pixel"
  echo "along the epipolar curve shows there, not in the pixel error)."
  echo
} > "$OUT"

for entry in "${SEQUENCES[@]}"; do
  IFS='|' read -r name synth_args config <<< "$entry"
  # shellcheck disable=SC2086  # synth_args are words
  key=$(printf '%s --frames %s' "$synth_args" "$FRAMES" | sha256sum | cut -c1-12)
  dataset=$CACHE/$name-$key
  if [[ ! -f "$dataset/meta.json" ]]; then
    echo "rendering $name ..." >&2
    # shellcheck disable=SC2086
    "$MCVO" synth $synth_args --frames "$FRAMES" --threads 2 --out "$dataset" --force > "$TMP/synth.log" 2>&1
  fi
  for anchor in false true; do
    python3 - "config/$config.json" "$anchor" "$TMP/$config.anchor_$anchor.json" <<'PY'
import json, sys
c = json.load(open(sys.argv[1]))
c.setdefault("frontend", {}).setdefault("anchor", {})["enabled"] = sys.argv[2] == "true"
json.dump(c, open(sys.argv[3], "w"), indent=1)
PY
    "$MCVO" track --dataset "$dataset" --config "$TMP/$config.anchor_$anchor.json" --threads 2 \
      --out "$TMP/$name.anchor_$anchor.trk" > "$TMP/track.log" 2>&1
    tail -1 "$TMP/track.log" | sed 's/^mcvo \[info\] track: //' > "$TMP/$name.anchor_$anchor.summary"
    "$BENCH" "$dataset" "$TMP/$name.anchor_$anchor.trk" "$TMP/$name.anchor_$anchor.true.trk" \
      > "$TMP/$name.anchor_$anchor.table"
  done
  {
    echo "## $name (config/$config.json)"
    echo
    echo "\`mcvo synth $synth_args --frames $FRAMES\`"
    echo
    for anchor in false true; do
      if [[ $anchor == true ]]; then echo "### anchor check on"; else echo "### LK only"; fi
      echo
      echo "Tracking: $(cat "$TMP/$name.anchor_$anchor.summary")"
      echo
      cat "$TMP/$name.anchor_$anchor.table"
      echo
    done
    echo "### Runs on these tracks"
    echo
    echo "| tracks | frames posed | ATE % of path | scale error % (signed) |"
    echo "|---|---|---|---|"
    echo "| LK only | $(run_summary "$dataset" "$TMP/$name.anchor_false.trk" "$TMP/$config.anchor_false.json" "$TMP/run_lk")"
    echo "| anchor check | $(run_summary "$dataset" "$TMP/$name.anchor_true.trk" "$TMP/$config.anchor_true.json" "$TMP/run_anchor")"
    echo "| LK-only features at their true pixels | $(run_summary "$dataset" "$TMP/$name.anchor_false.true.trk" "$TMP/$config.anchor_false.json" "$TMP/run_true")"
    if grep -q "cross-camera pair" "$TMP/$name.anchor_true.table"; then
      "$BENCH" "$dataset" "$TMP/$name.anchor_true.trk" "$TMP/$name.anchor_true.matches.trk" matches > /dev/null
      echo "| anchor check, each cross-camera match where b sees the point a's tracked pixel sees | $(run_summary "$dataset" "$TMP/$name.anchor_true.matches.trk" "$TMP/$config.anchor_true.json" "$TMP/run_matches")"
    fi
    echo
  } >> "$OUT"
done
cat "$OUT"
