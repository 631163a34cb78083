#!/usr/bin/env bash
# Throughput benchmark (issue 17, issue 58 item 3): how fast `mcvo track` and
# `mcvo run` go, against the time it takes only to decode the same images, and
# what a frame costs in CPU seconds beside the peers' on the same frames, on
# the machine it runs on, with accuracy beside every row. Writes
# results/throughput.md, results/throughput.csv (section 1) and
# results/throughput_peers.csv (section 2).
#
#   tools/bench_throughput.sh [FRAMES] [MCVO] [SCRATCH]
#       defaults: 60 frames (the kitti360 rows), build/mcvo,
#       ${TMPDIR:-/tmp}/mcvo_bench_throughput
#   env THREADS     threads of the kitti360 rows (default 2)
#   env ONLY_PEERS  1: section 2 only (a few minutes; for iteration); the md
#                   says so and results/throughput.csv is left as it is
#   env DATA        the real samples' folder (default ../shared/data/real)
#
# Section 1, data: the kitti360 preset (two 1408x376 pinhole, two 1400x1400
# MEI fisheyes) rendered once per FRAMES into SCRATCH at full and at half
# resolution (urban scene, 10 Hz, seed 13, 1 grey level of noise, 1 sample
# per pixel), as issue 17's example. Rigs: config/kitti360_{4,3,2}cam.json on
# the same images (4 cameras; 3 without overlap; the stereo pair).
# Detectors: shi_tomasi (the configs' default), orb, and xfeat
# (../shared/models/xfeat_480x640.onnx; 4 cameras only: it is the slowest).
#
# Colour rows ("full colour"): the full-resolution render copied as 3-channel
# PNGs by mcvo_bench_colourise (next to MCVO, or env COLOURISE), 4 and 2
# cameras, Shi-Tomasi: real rigs record colour, which costs more to decode.
# Per row, in one pass on the same machine, THREADS threads (default 2):
#   decode   `mcvo info --decode`: the rig's images decoded as `mcvo run`
#            decodes them (FrameStream), nothing else;
#   track    `mcvo track` (frontend only, writing a track file);
#   run      `mcvo run` (frontend, estimator, loop closure, evaluation,
#            COLMAP export, report: everything a user gets);
# each as frames/s, as time over the decode time, as CPU seconds (user +
# system of the command, tools/bench_common.sh seconds_of) per frame and as
# CPU ms per frame per megapixel (the config's cameras' pixels per frame);
# ATE (% of path, SE3) and scale error of the run beside it, so speed bought
# with accuracy shows. A profile of the full-resolution 4-camera Shi-Tomasi
# run at 1 and at 2 threads follows: the per-stage seconds of `mcvo track
# --timing` and of run.json's timing section.
#
# Section 2, the same frames as the peers (issue 58's CPU check): the stereo
# preset, 300 frames, half resolution (`synth --preset stereo --frames 300
# --image-scale 0.5 --scene open --noise 2 --seed 13`) with
# config/kitti360_2cam.json, and every sample of DATA that `mcvo info
# --dataset` reads (as tools/bench_real.sh finds them; built-in defaults, no
# --config); `mcvo run` at --threads 1 and 2 each; scored by `mcvo eval` as
# tools/bench_real.sh scores (SE3, Sim3 ATE %, scale error %; mm for a sample
# standing still); beside the peers' CPU s per frame (the data README's
# table; issue 58's for the render) and the target, half of ORB-SLAM3's.
# Section 3: issue 58's checks of the 4-camera rig at full resolution, from
# section 1's rows (frames/s at 2 threads; CPU per frame, 2 threads over 1).
# Section 4: where the suite's and the route's accuracy are (not rerun).
# The tables are made by tools/bench/throughput_report.py.
# Wall clock: numbers vary by a few percent from run to run; run on an idle
# machine. CPU seconds vary less.
set -euo pipefail
cd "$(dirname "$0")/.."
COMMAND_LINE="tools/bench_throughput.sh${*:+ $*}"
[[ ${ONLY_PEERS:-} == 1 ]] && COMMAND_LINE="ONLY_PEERS=1 $COMMAND_LINE"
[[ -n ${THREADS:-} && $THREADS != 2 ]] && COMMAND_LINE="THREADS=$THREADS $COMMAND_LINE"
[[ -n ${COLOURISE:-} ]] && COMMAND_LINE="COLOURISE=$COLOURISE $COMMAND_LINE"
FRAMES=${1:-60}
MCVO=${2:-build/mcvo}
SCRATCH=${3:-${TMPDIR:-/tmp}/mcvo_bench_throughput}
THREADS=${THREADS:-2}
DATA=${DATA:-../shared/data/real}
XFEAT=../shared/models/xfeat_480x640.onnx
COLOURISE=${COLOURISE:-$(dirname "$MCVO")/mcvo_bench_colourise}
REPORT=tools/bench/throughput_report.py
OUT_MD=results/throughput.md
OUT_CSV=results/throughput.csv
OUT_PEERS_CSV=results/throughput_peers.csv
mkdir -p "$SCRATCH"
LOAD_BEFORE=$(cut -d' ' -f1-3 /proc/loadavg)

render() {  # scale -> prints the sequence folder
  local scale=$1 seq="$SCRATCH/kitti360-$FRAMES-s$1"
  if [[ ! -f "$seq/frames.csv" ]]; then
    echo "rendering $FRAMES frames at image scale $scale into $seq ..." >&2
    "$MCVO" synth --preset kitti360 --frames "$FRAMES" --image-scale "$scale" --samples 1 --noise 1 --seed 13 \
      --threads "$THREADS" --force --out "$seq" >&2
  fi
  echo "$seq"
}

# shellcheck source=tools/bench_common.sh
source tools/bench_common.sh  # seconds_of

cameras_of() {  # config -> comma-separated camera list
  python3 -c "import json,sys; print(','.join(json.load(open(sys.argv[1]))['dataset']['cameras']))" "$1"
}

info_of() {  # dataset folder -> prints the file holding its `mcvo info --dataset` listing (made once)
  local info
  info="$SCRATCH/info_$(basename "$1").txt"
  [[ -s $info ]] || "$MCVO" info --dataset "$1" > "$info"
  echo "$info"
}

colourise() {  # grey sequence folder -> prints its colour copy's folder (tools/bench/colourise_bench.cc)
  local seq=$1 out="$1-colour"
  if [[ ! -f "$out/frames.csv" ]]; then
    rm -rf "$out"
    "$COLOURISE" "$seq" "$out" >&2
  fi
  echo "$out"
}

# Each sequence's files are read once, untimed, before its first row: every
# command then reads them from the page cache. Without this the first row's
# decode-only time, the baseline of its ratios, included reading the disk
# (38.7 against 62.7 frames/s for the same images one row later).
declare -A WARMED
warm() {  # seq
  [[ -n ${WARMED[$1]:-} ]] && return
  find "$1" -type f -exec cat {} + > /dev/null
  WARMED[$1]=1
}

row() {  # seq scale config detector threads [resolution label]
  local seq=$1 scale=$2 config=$3 detector=$4 threads=$5 label=${6:-}
  local cams decode track run extra=() name
  cams=$(cameras_of "config/$config.json")
  name="${scale}${label:+_$label}_${config}_${detector}_t${threads}"
  [[ $detector == xfeat ]] && extra=(--model "$XFEAT")
  warm "$seq"
  decode=$(seconds_of "$MCVO" info --dataset "$seq" --cameras "$cams" --decode --threads "$threads")
  track=$(seconds_of "$MCVO" track --dataset "$seq" --config "config/$config.json" --detector "$detector" \
    "${extra[@]}" --threads "$threads" --out "$SCRATCH/tracks.bin" --timing "$SCRATCH/track_$name.json")
  run=$(seconds_of "$MCVO" run --dataset "$seq" --config "config/$config.json" --detector "$detector" \
    "${extra[@]}" --threads "$threads" --force --out "$SCRATCH/run_$name")
  python3 "$REPORT" row "$SCRATCH/run_$name/run.json" "$(info_of "$seq")" "$cams" "$scale" "$detector" \
    "$threads" "$FRAMES" "$decode" "$track" "$run" "$label" >> "$OUT_CSV"
  tail -1 "$OUT_CSV" >&2
}

# ---- section 1: the kitti360 preset ----
if [[ ${ONLY_PEERS:-} != 1 ]]; then
  echo "resolution,cameras,detector,threads,frames,decode_s,track_s,run_s,decode_fps,track_fps,run_fps,\
track_over_decode,run_over_decode,scale,ate_percent,scale_error_percent,decode_cpu_s,track_cpu_s,run_cpu_s,\
megapixels,decode_cpu_s_per_frame,track_cpu_s_per_frame,run_cpu_s_per_frame,decode_cpu_ms_per_frame_mpx,\
track_cpu_ms_per_frame_mpx,run_cpu_ms_per_frame_mpx" > "$OUT_CSV"
  for scale in 1 0.5; do
    seq=$(render "$scale")
    for config in kitti360_4cam kitti360_3cam kitti360_2cam; do
      for detector in shi_tomasi orb xfeat; do
        [[ $detector == xfeat && $config != kitti360_4cam ]] && continue
        [[ $detector == xfeat && ! -f $XFEAT ]] && continue
        row "$seq" "$scale" "$config" "$detector" "$THREADS"
      done
    done
  done
  # The profile and issue 58's threads check: full resolution, 4 cameras, Shi-Tomasi, at 1 thread too.
  row "$(render 1)" 1 kitti360_4cam shi_tomasi 1
  # Colour input, as real rigs record it (KITTI-360's PNGs are RGB): the same
  # frames as 3-channel PNGs (2.6 x the bytes), full resolution, Shi-Tomasi.
  if [[ -x $COLOURISE ]]; then
    for config in kitti360_4cam kitti360_2cam; do
      row "$(colourise "$(render 1)")" 1 "$config" shi_tomasi "$THREADS" colour
    done
  else
    echo "no $COLOURISE: the colour rows are left out" >&2
  fi
fi

# ---- section 2: the same frames as the peers, at --threads 1 and 2 ----
PEER_RUNS="$SCRATCH/peer_runs.tsv"  # name kind config frames gt threads run_dir wall user sys info
PEER_SKIPPED="$SCRATCH/peer_skipped.tsv"
: > "$PEER_RUNS"
: > "$PEER_SKIPPED"
peer_runs() {  # name kind dataset config(or empty) gt
  local name=$1 kind=$2 dir=$3 config=$4 gt=$5 info frames args=() out t wall user sys
  info=$(info_of "$dir")
  frames=$(awk '$1 == "frames" {print $2; exit}' "$info" | tr -d ,)
  [[ -n $config ]] && args=(--config "$config")
  warm "$dir"
  # 2 and 1 threads on every frame; then 1 thread on the first half only ("1h"): the difference of the
  # two 1-thread runs over the frames between is the CPU of a further frame, without the start-up.
  for threads in 2 1 1h; do
    out="$SCRATCH/peer_${name}_t$threads"
    local n=$frames extra=()
    [[ $threads == 1h ]] && { n=$((frames / 2)); extra=(--frames "$n"); }
    t=$(seconds_of "$MCVO" run --dataset "$dir" "${args[@]}" "${extra[@]}" --threads "${threads%h}" --force \
      --out "$out")
    read -r wall user sys < "$SCRATCH/last.usage"
    printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$name" "$kind" "$config" "$n" "$gt" "$threads" \
      "$out" "$wall" "$user" "$sys" "$info" >> "$PEER_RUNS"
    echo "$name --threads ${threads%h}${extra[*]:+ ${extra[*]}}: $t (wall, cpu s) over $n frames" >&2
  done
}
stereo="$SCRATCH/stereo-300-s0.5-open-n2-seed13"
if [[ ! -f "$stereo/frames.csv" ]]; then
  echo "rendering the stereo preset, 300 frames, half resolution, into $stereo ..." >&2
  "$MCVO" synth --preset stereo --frames 300 --image-scale 0.5 --scene open --noise 2 --seed 13 \
    --threads "$THREADS" --force --out "$stereo" >&2
fi
peer_runs synthetic_stereo synthetic "$stereo" config/kitti360_2cam.json "$stereo/groundtruth.tum"
[[ -d $DATA ]] || { echo "bench_throughput.sh: no sample folder $DATA" >&2; exit 1; }
for dir in "$DATA"/*/; do  # as tools/bench_real.sh: every folder `mcvo info --dataset` reads
  dir=${dir%/}
  sample=$(basename "$dir")
  info="$SCRATCH/info_$sample.txt"
  if ! "$MCVO" info --dataset "$dir" > "$info" 2>&1; then
    printf '%s\t%s\n' "$sample" "$(grep -m1 . "$info" | tr '\t' ' ')" >> "$PEER_SKIPPED"
    rm -f "$info"
    continue
  fi
  gt=-
  for g in groundtruth.tum groundtruth_tum.txt mav0/state_groundtruth_estimate0/data.csv; do
    [[ -f $dir/$g ]] && { gt=$dir/$g; break; }
  done
  peer_runs "$sample" real "$dir" "" "$gt"
done
LOAD_AFTER=$(cut -d' ' -f1-3 /proc/loadavg)

python3 "$REPORT" report "$([[ ${ONLY_PEERS:-} == 1 ]] && echo only_peers || echo all)" "$OUT_CSV" "$PEER_RUNS" \
  "$PEER_SKIPPED" "$OUT_PEERS_CSV" "$SCRATCH" "$FRAMES" "$THREADS" "$MCVO" "$DATA" "$COMMAND_LINE" \
  "$LOAD_BEFORE" "$LOAD_AFTER" > "$OUT_MD"
cat "$OUT_MD"
