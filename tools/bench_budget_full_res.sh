#!/usr/bin/env bash
# The feature budget of large pinhole cameras on full-resolution renders
# (results/feature_budget.md, "Full-resolution KITTI-360 renders"): the
# kitti360 preset (two 1408x376 pinholes = 0.53 Mpx, 212 features with the
# default frontend.max_features_pinhole_megapixels 0.25; two MEI fisheyes,
# unchanged) at full resolution, 100 frames, three scenes and seeds (urban
# s201 noise 1; urban_block s202 with the KITTI-like realism of
# results/render_realism.md; open s203 noise 1), each run with
# config/kitti360_4cam.json and kitti360_2cam.json as they are and with
# max_features_pinhole_megapixels 0 (100 features, the earlier budget).
# Prints one line per run: ATE and scale error from `mcvo run`'s own
# evaluation (SE3), user and system CPU seconds.
#
#   tools/bench_budget_full_res.sh [MCVO] [SCRATCH]
#       defaults: build/mcvo, ${TMPDIR:-/tmp}/mcvo_bench_budget_full_res
set -euo pipefail
cd "$(dirname "$0")/.."
M=${1:-build/mcvo}
W=${2:-${TMPDIR:-/tmp}/mcvo_bench_budget_full_res}
mkdir -p "$W"
render() {  # name scene seed effects...
  local n=$1 sc=$2 sd=$3
  shift 3
  [[ -f $W/seq_$n/groundtruth.tum ]] ||
    "$M" synth --preset kitti360 --frames 100 --scene "$sc" --seed "$sd" "$@" --out "$W/seq_$n" --force > "$W/synth_$n.log" 2>&1
}
render urban_s201 urban 201 --noise 1
render block_s202_real urban_block 202 --sensor-noise 0.033:0 --lens-blur 0.8 --tone 1.5:1.5
render open_s203 open 203 --noise 1
for n in urban_s201 block_s202_real open_s203; do
  for cfg in kitti360_4cam kitti360_2cam; do
    for lever in mp0 default; do
      c=$W/cfg_${cfg}_$lever.json
      /usr/bin/python3 - "config/$cfg.json" "$lever" "$c" <<'PY'
import json, re, sys
src, lever, out = sys.argv[1:]
c = json.loads(re.sub(r"^\s*//.*$", "", open(src).read(), flags=re.M))
if lever == "mp0":
    c.setdefault("frontend", {})["max_features_pinhole_megapixels"] = 0
json.dump(c, open(out, "w"), indent=1)
PY
      log=$W/log_${n}_${cfg}_$lever
      /usr/bin/time -f "%U %S" -o "$W/time_${n}_${cfg}_$lever" "$M" run --dataset "$W/seq_$n" --config "$c" \
        --threads 2 --force --out "$W/run_${n}_${cfg}_$lever" > "$log" 2>&1
      echo "$n $cfg $lever $(grep -o 'ATE rmse.*' "$log" | tail -1) cpu $(cat "$W/time_${n}_${cfg}_$lever")"
    done
  done
done
