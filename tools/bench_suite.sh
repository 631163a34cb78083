#!/usr/bin/env bash
# Robustness benchmark suite of `mcvo run` ("odometry that holds on every
# sequence, not one route"): 32 synthetic sequences of FRAMES (300) frames,
# 7 rigs x 4 scenes (urban, urban_block, indoor, open) x seeds x image
# effects (noise, exposure changes, vignetting, motion blur, one camera
# blacked out for a while), 38 runs through `mcvo batch`. Writes
# results/suite.md and results/suite.csv and prints the tables.
#
#   tools/bench_suite.sh [--list] [MCVO] [SCRATCH]
#       defaults: build/mcvo, ${TMPDIR:-/tmp}/mcvo_suite
#   env FRAMES   frames per sequence (default 300; fewer only for a smoke test)
#   env ONLY     a regex (bash =~) on sequence names: run only those
#   env SCALE    multiplies every image scale (default 1; below 1 only for a smoke test,
#                e.g. FRAMES=12 SCALE=0.4 ONLY='^(st_urban_s21_noise|tri_indoor_s52_noise)$')
#   env OUT_BASE where the tables go (default results/suite, results/suite_monocular,
#                results/suite_heldout by SUITE; with ONLY, name another, e.g.
#                results/suite_near_warp, so the whole suite's tables stay)
#   env SET      config overrides for every run, space-separated key=JSON pairs, e.g.
#                SET='frontend.cross_camera.equalised=false frontend.cross_camera.normalise_sigma_px=8'
#                (an A/B run of one setting over the suite; the tables name them)
#   env SUITE    main (default) | monocular: the one-camera suite instead (16 sequences,
#                4 one-camera rigs x 4 scenes; results/suite_monocular.md and .csv)
#                | heldout: 8 sequences of the main suite's rigs and configs on seeds
#                101-108 that no change was tuned on (results/suite_heldout.md and .csv)
#                | small: 17 sequences of the main suite's rigs and configs with cameras of
#                150-240 px (image scales 0.25-0.35, seeds 311-327; results/suite_small.md)
#   --list       print the sequences, their configs and synth arguments; run nothing
#
# What it measures, per run (run.json of each run): frames posed %, segments
# (tracking losses + 1), ATE rmse as % of the ground-truth path over the posed
# frames with SE3 alignment, no scale fitted (eval.align = "se3", the default
# that every config used here keeps; the summary checks run.json), the Sim3
# scale error 100 |1/s - 1|, frames/s (wall clock, 2 threads, not
# deterministic) and the run's warning. Per rig and config: median and worst
# of those, and how many sequences meet the targets: frames posed >= 99 %;
# 3-camera rigs ATE <= 0.5 % and scale error <= 1 %; every other rig (2, 4,
# 5, 6 cameras) ATE <= 0.3 %. The outputs are deterministic (fixed seeds,
# byte-identical at any thread count) except frames/s and wall times.
#
# Rigs, scales (each frame at most ~0.5 Mpx over all cameras, except the
# KITTI-360 rigs at half resolution as in tools/bench_run.sh) and configs.
# ONE config per rig, never per sequence:
#   kitti360       preset, 0.5  (1.25 Mpx)  config/kitti360_4cam.json AND
#                                           config/kitti360_2cam.json on the same render
#   kitti360-3cam  preset, 0.5  (1.11 Mpx)  config/kitti360_3cam.json
#   stereo         preset, 0.5  (0.26 Mpx)  config/kitti360_2cam.json: the preset IS the
#                                           KITTI-360 stereo pair (image_00, image_01), so it
#                                           gets the 2-cam config, comparable to kitti360 + 2cam
#   multicam6      preset, 0.45 (0.47 Mpx)  config/multicam6.json
#   irregular5     preset, 0.48 (0.48 Mpx)  config/synthetic.json
#   tri_rear       config/rigs/suite/tri_rear.json, 0.5 (0.46 Mpx): Kannala-Brandt front-left,
#                  double-sphere rear, radtan right, odd angles; only rear/right overlap
#                                           config/synthetic.json
#   roof_pair      config/rigs/suite/roof_pair.json, 0.8 (0.46 Mpx): radtan (EuRoC-like)
#                  pair, 0.12 m baseline on the roof, 14 deg down, unrectified
#                                           config/synthetic.json
# No rig needs a config of its own: synthetic.json (the defaults: the
# KITTI-360 configs' feature counts, eval.align se3 spelled out) fits any rig
# whose cameras overlap somewhere (cross-camera matching on, all cameras used);
# tri_rear's rear and right cameras share 19-38 % of their views, so it is not
# the non-overlapping case kitti360_3cam.json relaxes the initializer for.
# The KITTI-360 3-camera rig gets no `urban` sequence: the first 300 frames of
# that route are a straight road (0 deg of turning for most seeds), where a
# rig without overlap cannot observe its scale at all; urban_block, indoor and
# open turn within 13-130 frames.
#
# Rendering (`mcvo synth --threads 2`, one sequence at a time) is cached in
# SCRATCH/seq/<name>-<hash>, the hash being SHA-256 of the full synth
# argument list (and of the rig file's content for --rig); a sequence is
# rendered only when its folder lacks frames.csv. Render time: one 5-frame
# trial render per rig at 0.25 image scale (urban scene; multicam6 indoor),
# s/Mpx at 2 threads with 2x2 samples per pixel, scaled to the suite's image
# size. Measured on the 2-core AMD EPYC while two other 1-thread renders and a
# compiler shared its cores (load 2.7-3.6), so these are upper bounds; idle,
# tools/bench_synth.sh measures 0.36-0.69 s/Mpx at full resolution:
#   rig            s/Mpx  Mpx    s/frame  300-frame sequence
#   kitti360       1.69   1.25   2.1      10.5 min (indoor 0.63x, open 0.78x of urban)
#   kitti360-3cam  1.62   1.11   1.8       9 min
#   stereo         1.57   0.26   0.42      2.1 min
#   multicam6      0.74   0.47   0.35      1.7 min (indoor; urban ~1.6x)
#   irregular5     1.71   0.48   0.82      4.1 min
#   tri_rear       1.84   0.46   0.85      4.3 min
#   roof_pair      1.86   0.46   0.86      4.3 min
#   --motion-blur 3 costs 2.9x.
# Whole suite at 300 frames: measured 2026-11-25, 9001 s (2.5 h) of
# rendering once (most of it while other work shared the cores; the cache
# keeps it), and the 38 runs (11,400 frames, one at a time, 2 threads each)
# took 505 s (8.4 min) on the idle 2-core machine, 555 s (9.3 min) after the
# overlap start (3 more sequences posed): within the 60 min budget.
# The summary states both wall times and the machine.
set -euo pipefail

LIST=0
POSITIONAL=()
for arg in "$@"; do
  case "$arg" in
    --list) LIST=1 ;;
    -h | --help) sed -n '2,26p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "bench_suite.sh: unknown option $arg" >&2; exit 2 ;;
    *) POSITIONAL+=("$arg") ;;
  esac
done
CALLER_DIR=$PWD
cd "$(dirname "$0")/.."
ROOT=$PWD
absolute() { case "$1" in /*) echo "$1" ;; *) echo "$CALLER_DIR/$1" ;; esac; }
if [[ -n "${POSITIONAL[0]:-}" ]]; then MCVO=$(absolute "${POSITIONAL[0]}"); else MCVO=$ROOT/build/mcvo; fi
SCRATCH=$(absolute "${POSITIONAL[1]:-${TMPDIR:-/tmp}/mcvo_suite}")
FRAMES=${FRAMES:-300}
ONLY=${ONLY:-}
SCALE=${SCALE:-1}
THREADS=2
if ! [[ "$FRAMES" =~ ^[1-9][0-9]*$ ]]; then
  echo "bench_suite.sh: FRAMES must be a positive integer, got '$FRAMES'" >&2
  exit 2
fi
if ! [[ "$SCALE" =~ ^[0-9]*\.?[0-9]+$ ]] || awk -v s="$SCALE" 'BEGIN { exit !(s <= 0 || s > 2) }'; then
  echo "bench_suite.sh: SCALE must be a number in (0, 2], got '$SCALE'" >&2
  exit 2
fi
# One camera black from 2/5 of the sequence for 1/6 of it (frames 120-169 of 300).
BLACK="$((FRAMES * 2 / 5)):$((FRAMES / 6 > 0 ? FRAMES / 6 : 1))"

# ---- the suite ---------------------------------------------------------------
# suite NAME RIG SCALE SCENE SEED CONFIGS [EFFECT FLAGS...]
#   RIG: preset:<name> or a rig.json path relative to the repository root;
#   CONFIGS: comma-separated config names under config/ (without .json).
NAMES=() RIGS=() SCALES=() SCENES=() SEEDS=() CONFIGS=() EFFECTS=()
suite() {
  NAMES+=("$1") RIGS+=("$2") SCALES+=("$3") SCENES+=("$4") SEEDS+=("$5") CONFIGS+=("$6")
  shift 6
  EFFECTS+=("$*")
}
K4=kitti360_4cam,kitti360_2cam
TRI=config/rigs/suite/tri_rear.json
ROOF=config/rigs/suite/roof_pair.json
suite k360_urban_s1          preset:kitti360      0.5  urban       1  $K4
suite k360_urban_s2_noise    preset:kitti360      0.5  urban       2  $K4 --noise 2
suite k360_block_s3_expo     preset:kitti360      0.5  urban_block 3  $K4 --exposure-changes --vignetting
suite k360_indoor_s4_noise   preset:kitti360      0.5  indoor      4  $K4 --noise 2 --vignetting
suite k360_open_s5_blur      preset:kitti360      0.5  open        5  $K4 --motion-blur 3
suite k360_urban_s6_blackout preset:kitti360      0.5  urban       6  $K4 --noise 1 --blackout "image_00:$BLACK"
suite k3_block_s11           preset:kitti360-3cam 0.5  urban_block 11 kitti360_3cam
suite k3_block_s12_expo      preset:kitti360-3cam 0.5  urban_block 12 kitti360_3cam --exposure-changes --vignetting --noise 1
suite k3_indoor_s13_noise    preset:kitti360-3cam 0.5  indoor      13 kitti360_3cam --noise 2
suite k3_open_s14            preset:kitti360-3cam 0.5  open        14 kitti360_3cam
suite k3_block_s15_blackout  preset:kitti360-3cam 0.5  urban_block 15 kitti360_3cam --blackout "image_02:$BLACK"
suite st_urban_s21_noise     preset:stereo        0.5  urban       21 kitti360_2cam --noise 2
suite st_block_s22_blur      preset:stereo        0.5  urban_block 22 kitti360_2cam --motion-blur 3
suite st_indoor_s23_expo     preset:stereo        0.5  indoor      23 kitti360_2cam --exposure-changes --vignetting
suite st_open_s24_blackout   preset:stereo        0.5  open        24 kitti360_2cam --blackout "image_01:$BLACK"
suite mc6_indoor_s31         preset:multicam6     0.45 indoor      31 multicam6
suite mc6_indoor_s32_noise   preset:multicam6     0.45 indoor      32 multicam6 --noise 2 --exposure-changes
suite mc6_urban_s33_vign     preset:multicam6     0.45 urban       33 multicam6 --vignetting
suite mc6_open_s34_blur      preset:multicam6     0.45 open        34 multicam6 --motion-blur 3
suite mc6_block_s35_blackout preset:multicam6     0.45 urban_block 35 multicam6 --blackout "cam1:$BLACK"
suite irr5_urban_s41         preset:irregular5    0.48 urban       41 synthetic
suite irr5_block_s42_noise   preset:irregular5    0.48 urban_block 42 synthetic --noise 2 --vignetting
suite irr5_indoor_s43_expo   preset:irregular5    0.48 indoor      43 synthetic --exposure-changes
suite irr5_open_s44_blackout preset:irregular5    0.48 open        44 synthetic --blackout "front_tilted:$BLACK"
suite tri_block_s51          $TRI                 0.5  urban_block 51 synthetic
suite tri_indoor_s52_noise   $TRI                 0.5  indoor      52 synthetic --noise 2
suite tri_open_s53_expo      $TRI                 0.5  open        53 synthetic --exposure-changes --vignetting
suite tri_urban_s54_blur     $TRI                 0.5  urban       54 synthetic --motion-blur 3
suite roof_urban_s61         $ROOF                0.8  urban       61 synthetic
suite roof_block_s62_noise   $ROOF                0.8  urban_block 62 synthetic --noise 2
suite roof_indoor_s63_expo   $ROOF                0.8  indoor      63 synthetic --exposure-changes --vignetting
suite roof_open_s64_blackout $ROOF                0.8  open        64 synthetic --noise 1 --blackout "roof_right:$BLACK"

# The monocular suite (SUITE=monocular): one-camera rigs, run at an arbitrary
# scale (estimator.h "Monocular") and evaluated with a similarity; one config
# (synthetic.json) for all. Rigs: the `mono` preset (KITTI-360 image_00,
# pinhole 1408x376), and config/rigs/suite/mono_*.json: KITTI-360's left MEI
# fisheye (looking sideways), tri_rear's Kannala-Brandt front-left camera
# (yawed and pitched), roof_pair's radtan camera (14 deg down); each at least
# 0.7 m from its rig origin. Every rig in every scene, seeds and effects varied.
SUITE=${SUITE:-main}
USER_OUT_BASE=${OUT_BASE:-}
OUT_BASE=${OUT_BASE:-results/suite}
case "$SUITE" in
  main) ;;
  monocular)
    OUT_BASE=${USER_OUT_BASE:-results/suite_monocular}
    NAMES=() RIGS=() SCALES=() SCENES=() SEEDS=() CONFIGS=() EFFECTS=()
    MFISH=config/rigs/suite/mono_fisheye.json
    MKB=config/rigs/suite/mono_kb.json
    MROOF=config/rigs/suite/mono_roof.json
    suite mono_urban_s71          preset:mono 0.5  urban       71 synthetic
    suite mono_block_s72_noise    preset:mono 0.5  urban_block 72 synthetic --noise 2
    suite mono_indoor_s73_expo    preset:mono 0.5  indoor      73 synthetic --exposure-changes --vignetting
    suite mono_open_s74_blur      preset:mono 0.5  open        74 synthetic --motion-blur 3
    suite mfish_urban_s81_noise   $MFISH      0.35 urban       81 synthetic --noise 2
    suite mfish_block_s82         $MFISH      0.35 urban_block 82 synthetic
    suite mfish_indoor_s83_vign   $MFISH      0.35 indoor      83 synthetic --vignetting
    suite mfish_open_s84_expo     $MFISH      0.35 open        84 synthetic --exposure-changes
    suite mkb_urban_s91_expo      $MKB        0.5  urban       91 synthetic --exposure-changes --vignetting
    suite mkb_block_s92_blur      $MKB        0.5  urban_block 92 synthetic --motion-blur 3
    suite mkb_indoor_s93_noise    $MKB        0.5  indoor      93 synthetic --noise 2
    suite mkb_open_s94            $MKB        0.5  open        94 synthetic
    suite mroof_urban_s101        $MROOF      0.8  urban       101 synthetic
    suite mroof_block_s102_vign   $MROOF      0.8  urban_block 102 synthetic --vignetting --noise 1
    suite mroof_indoor_s103_blur  $MROOF      0.8  indoor      103 synthetic --motion-blur 3
    suite mroof_open_s104_noise   $MROOF      0.8  open        104 synthetic --noise 2
    ;;
  heldout)
    # Held out: rendered and run for the first time on 2026-11-27 (after
    # every setting they would judge was chosen) to see the suite's targets
    # on seeds nothing was tuned on. Never tune on them; when a change is
    # judged on them, add new seeds.
    OUT_BASE=${USER_OUT_BASE:-results/suite_heldout}
    NAMES=() RIGS=() SCALES=() SCENES=() SEEDS=() CONFIGS=() EFFECTS=()
    suite st_indoor_s101_noise   preset:stereo        0.5  indoor      101 kitti360_2cam --noise 1
    suite st_block_s102_expo     preset:stereo        0.5  urban_block 102 kitti360_2cam --exposure-changes
    suite mc6_indoor_s103_vign   preset:multicam6     0.45 indoor      103 multicam6 --vignetting
    suite mc6_open_s104          preset:multicam6     0.45 open        104 multicam6
    suite roof_urban_s105_noise  $ROOF                0.8  urban       105 synthetic --noise 1
    suite tri_block_s106_expo    $TRI                 0.5  urban_block 106 synthetic --exposure-changes
    suite st_indoor_s107         preset:stereo        0.5  indoor      107 kitti360_2cam
    suite k3_block_s108          preset:kitti360-3cam 0.5  urban_block 108 kitti360_3cam
    ;;
  small)
    # Small cameras: every rig has cameras whose sqrt(width x height) is
    # 156-240 px, under the frontend's pixel_scale_reference_px of 250 (the
    # KITTI-360 rigs: 352 x 94 pinholes beside 350 x 350 fisheyes). The main
    # suite's rigs and configs at a half to a third of its image scales, on seeds 311-327 that
    # nothing was tuned on (the rule was set from seeds 285 and 289,
    # results/fresh_seeds_s281.md). In the main suite only irregular5's
    # 246 x 184 px camera (213 px) is under the reference.
    OUT_BASE=${USER_OUT_BASE:-results/suite_small}
    NAMES=() RIGS=() SCALES=() SCENES=() SEEDS=() CONFIGS=() EFFECTS=()
    suite k360_urban_s311_noise  preset:kitti360      0.25 urban       311 $K4 --noise 1
    suite k3_block_s312          preset:kitti360-3cam 0.25 urban_block 312 kitti360_3cam
    suite st_block_s313_noise    preset:stereo        0.25 urban_block 313 kitti360_2cam --noise 2
    suite st_indoor_s314         preset:stereo        0.25 indoor      314 kitti360_2cam
    suite mc6_urban_s315_noise   preset:multicam6     0.25 urban       315 multicam6 --noise 1
    suite mc6_indoor_s316_expo   preset:multicam6     0.25 indoor      316 multicam6 --exposure-changes
    suite irr5_urban_s317_noise  preset:irregular5    0.3  urban       317 synthetic --noise 1
    suite irr5_block_s318_vign   preset:irregular5    0.3  urban_block 318 synthetic --vignetting
    suite tri_open_s319          $TRI                 0.25 open        319 synthetic
    suite roof_block_s320_noise  $ROOF                0.35 urban_block 320 synthetic --noise 1
    suite k360_block_s321_expo   preset:kitti360      0.25 urban_block 321 $K4 --exposure-changes
    suite k3_indoor_s322_noise   preset:kitti360-3cam 0.25 indoor      322 kitti360_3cam --noise 1
    suite st_urban_s323          preset:stereo        0.25 urban       323 kitti360_2cam
    suite mc6_open_s324          preset:multicam6     0.25 open        324 multicam6
    suite irr5_open_s325_noise   preset:irregular5    0.3  open        325 synthetic --noise 1
    suite tri_block_s326_vign    $TRI                 0.25 urban_block 326 synthetic --vignetting
    suite roof_urban_s327        $ROOF                0.35 urban       327 synthetic
    ;;
  *) echo "bench_suite.sh: SUITE must be main, monocular, heldout or small, got '$SUITE'" >&2; exit 2 ;;
esac

# ---- synth arguments and cache folders ---------------------------------------
rig_label() { case "$1" in preset:*) echo "${1#preset:}" ;; *) basename "$1" .json ;; esac; }
synth_args() {  # index -> SYNTH_ARGS (everything but --out, --force and --threads)
  local i=$1
  case "${RIGS[$i]}" in
    preset:*) SYNTH_ARGS=(--preset "${RIGS[$i]#preset:}") ;;
    *) SYNTH_ARGS=(--rig "${RIGS[$i]}") ;;
  esac
  local scale=${SCALES[$i]}
  [[ "$SCALE" == 1 ]] || scale=$(awk -v a="$scale" -v b="$SCALE" 'BEGIN { printf "%.4g", a * b }')
  # shellcheck disable=SC2206  # effect flags are single words
  SYNTH_ARGS+=(--scene "${SCENES[$i]}" --frames "$FRAMES" --seed "${SEEDS[$i]}" --image-scale "$scale"
               ${EFFECTS[$i]})
}
# Renders of a scene from before a change of what `mcvo synth` draws for the
# same arguments are stale: such a change adds a line here, which changes
# the hash of that scene's sequences only.
scene_revision() {
  case "$1" in
    # 2026-11-26: rigs lowered to keep every camera 0.3 m under the 2.8 m
    # ceiling (synthesize.cc, FitRigHeight); irregular5, tri_rear and
    # roof_pair had cameras in or above it.
    # 2026-11-27: rigs carried by the middle of their cameras, doorways open
    # to the ceiling (synthesize.cc, FitRigToRoom; scene_indoor.cc): the
    # KITTI-360 rigs' cameras, 1.6 m ahead of their origin, swung through
    # the walls at the corners and passed through the doorways' lintels.
    indoor) echo "indoor: rig fitted under the ceiling; carried by the middle of its cameras" ;;
  esac
}
seq_dir() {  # index -> SEQ_DIR (needs SYNTH_ARGS of that index)
  local i=$1 key revision
  key=$(printf '%s\n' "${SYNTH_ARGS[@]}")
  revision=$(scene_revision "${SCENES[$i]}")
  [[ -z "$revision" ]] || key+=$'\n'"$revision"
  case "${RIGS[$i]}" in
    preset:*) ;;
    *) key+=$'\n'"rig sha256 $(sha256sum "${RIGS[$i]}" | cut -d' ' -f1)" ;;
  esac
  SEQ_DIR="$SCRATCH/seq/${NAMES[$i]}-$(printf '%s' "$key" | sha256sum | cut -c1-12)"
}

SELECTED=()
for i in "${!NAMES[@]}"; do
  if [[ -z "$ONLY" || "${NAMES[$i]}" =~ $ONLY ]]; then SELECTED+=("$i"); fi
done
if [[ ${#SELECTED[@]} -eq 0 ]]; then
  echo "bench_suite.sh: ONLY='$ONLY' matches no sequence (--list shows them)" >&2
  exit 2
fi

if [[ $LIST == 1 ]]; then
  echo "# ${#SELECTED[@]} of ${#NAMES[@]} sequences, FRAMES=$FRAMES, SCALE=$SCALE; folders under $SCRATCH/seq/"
  printf '%-24s %-14s %-30s %-12s %-5s %s\n' name rig configs scene seed "folder / mcvo synth arguments"
  for i in "${SELECTED[@]}"; do
    synth_args "$i"
    seq_dir "$i"
    printf '%-24s %-14s %-30s %-12s %-5s %s\n' "${NAMES[$i]}" "$(rig_label "${RIGS[$i]}")" "${CONFIGS[$i]}" \
      "${SCENES[$i]}" "${SEEDS[$i]}" "$(basename "$SEQ_DIR")"
    printf '%-24s mcvo synth %s --threads %s --out %s\n' "" "${SYNTH_ARGS[*]}" "$THREADS" "$(basename "$SEQ_DIR")"
  done
  exit 0
fi

[[ -x "$MCVO" ]] || { echo "bench_suite.sh: $MCVO is not an executable" >&2; exit 2; }
mkdir -p "$SCRATCH/seq" "$SCRATCH/runs" results
now() { date +%s.%N; }
elapsed() { awk -v a="$1" -v b="$2" 'BEGIN { printf "%.1f", b - a }'; }

# ---- render (sequentially, 2 threads) ----------------------------------------
RUNS_TSV="$SCRATCH/suite_runs.tsv"
printf 'sequence\trig\tscene\tseed\teffects\tconfig\trun\tdataset\trender_s\trender_status\n' > "$RUNS_TSV"
render_total=0 rendered=0 cached=0 render_failed=0
for i in "${SELECTED[@]}"; do
  synth_args "$i"
  seq_dir "$i"
  name=${NAMES[$i]}
  status=ok
  if [[ -f "$SEQ_DIR/frames.csv" ]]; then
    cached=$((cached + 1))
    echo "render $name: cached in $SEQ_DIR" >&2
  else
    echo "render $name: mcvo synth ${SYNTH_ARGS[*]} --threads $THREADS" >&2
    start=$(now)
    if "$MCVO" synth "${SYNTH_ARGS[@]}" --threads "$THREADS" --out "$SEQ_DIR" --force \
        > "$SEQ_DIR.log" 2>&1; then
      seconds=$(elapsed "$start" "$(now)")
      render_total=$(awk -v a="$render_total" -v b="$seconds" 'BEGIN { print a + b }')
      rendered=$((rendered + 1))
      printf '%s\n' "$seconds" > "$SEQ_DIR.render_s"
      echo "  $(grep -o 'wrote.*' "$SEQ_DIR.log" | tail -1) [${seconds} s whole command]" >&2
    else
      status=failed
      render_failed=$((render_failed + 1))
      echo "  FAILED (log: $SEQ_DIR.log): $(tail -1 "$SEQ_DIR.log")" >&2
    fi
  fi
  render_s=$(cat "$SEQ_DIR.render_s" 2>/dev/null || echo "")
  IFS=, read -r -a configs <<< "${CONFIGS[$i]}"
  for config in "${configs[@]}"; do
    printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$name" "$(rig_label "${RIGS[$i]}")" "${SCENES[$i]}" \
      "${SEEDS[$i]}" "${EFFECTS[$i]:-none}" "$config" "$name.$config" "$SEQ_DIR" "$render_s" "$status" \
      >> "$RUNS_TSV"
  done
done

# ---- runs: one mcvo batch, one run at a time, 2 threads each -----------------
MANIFEST="$SCRATCH/suite_manifest.json"
python3 - "$RUNS_TSV" "$ROOT" "$THREADS" "$SCRATCH" "${SET:-}" > "$MANIFEST" <<'PY'
import csv, json, os, sys
tsv, root, threads, scratch, overrides = sys.argv[1], sys.argv[2], int(sys.argv[3]), sys.argv[4], sys.argv[5]
def config_path(name):
    path = os.path.join(root, "config", name + ".json")
    if not overrides.split():
        return path
    config = json.load(open(path))
    for pair in overrides.split():
        key, value = pair.split("=", 1)
        node = config
        for part in key.split(".")[:-1]:
            node = node.setdefault(part, {})
        node[key.split(".")[-1]] = json.loads(value)
    os.makedirs(os.path.join(scratch, "configs"), exist_ok=True)
    out = os.path.join(scratch, "configs", name + ".json")
    json.dump(config, open(out, "w"), indent=1)
    return out
runs = [{"name": r["run"], "dataset": {"root": r["dataset"], "format": "generic"},
         "config": config_path(r["config"]), "threads": threads}
        for r in csv.DictReader(open(tsv), delimiter="\t") if r["render_status"] == "ok"]
json.dump({"runs": runs}, sys.stdout, indent=2)
print()
PY
batch_rc=0
batch_s=0
if python3 -c 'import json,sys; sys.exit(0 if json.load(open(sys.argv[1]))["runs"] else 1)' "$MANIFEST"; then
  echo "batch: $(grep -c '"name"' "$MANIFEST") runs -> $SCRATCH/runs" >&2
  start=$(now)
  # Its log and summary table go to stderr (and batch.log): stdout is the suite's table only.
  # --force: every run again, so the wall times are this invocation's
  # (batch's up-to-date check would rerun only runs of another build).
  "$MCVO" batch --manifest "$MANIFEST" --jobs 1 --force --out "$SCRATCH/runs" 2>&1 | tee "$SCRATCH/batch.log" >&2 ||
    batch_rc=${PIPESTATUS[0]}
  batch_s=$(elapsed "$start" "$(now)")
  echo "batch: exit $batch_rc after $batch_s s (log: $SCRATCH/batch.log)" >&2
else
  echo "batch: nothing to run (every render failed)" >&2
fi

# ---- summary -----------------------------------------------------------------
SUITE_CPU=$(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//' || true)
SUITE_COMMIT=$(git rev-parse --short HEAD 2>/dev/null || echo unknown)
git diff --quiet HEAD -- src include tools config 2>/dev/null || SUITE_COMMIT+=" (with local changes)"
SUITE_VERSION=$("$MCVO" version 2>/dev/null | head -1 || true)
export SET FRAMES ONLY SUITE_CPU SUITE_COMMIT SUITE_VERSION SUITE OUT_BASE
SUITE_NPROC=$(nproc)
SUITE_DATE=$(date -u '+%Y-%m-%d %H:%M UTC')
export SUITE_NPROC SUITE_DATE SUITE_RENDER_S=$render_total \
  SUITE_RENDERED=$rendered SUITE_CACHED=$cached SUITE_RENDER_FAILED=$render_failed SUITE_BATCH_S=$batch_s \
  SUITE_BATCH_RC=$batch_rc SUITE_TOTAL_SEQUENCES=${#NAMES[@]}
python3 - "$RUNS_TSV" "$SCRATCH/runs" <<'PY'
import csv, json, math, os, statistics, sys

tsv, runs_dir = sys.argv[1], sys.argv[2]
e = os.environ
info = dict(frames=int(e["FRAMES"]), only=e.get("ONLY", ""), overrides=e.get("SET", ""), nproc=e["SUITE_NPROC"], cpu=e["SUITE_CPU"],
            commit=e["SUITE_COMMIT"], version=e["SUITE_VERSION"], date=e["SUITE_DATE"],
            render_s=float(e["SUITE_RENDER_S"]), rendered=int(e["SUITE_RENDERED"]), cached=int(e["SUITE_CACHED"]),
            render_failed=int(e["SUITE_RENDER_FAILED"]), batch_s=float(e["SUITE_BATCH_S"]),
            batch_rc=int(e["SUITE_BATCH_RC"]), total_sequences=int(e["SUITE_TOTAL_SEQUENCES"]))
nan = float("nan")


def num(x):
    return x if isinstance(x, (int, float)) and not isinstance(x, bool) else nan


def expected_cameras(r):
    """Cameras a run uses, from its config's dataset.cameras or the sequence's rig.json (for failed runs too)."""
    try:
        cameras = json.load(open(os.path.join("config", r["config"] + ".json"))).get("dataset", {}).get("cameras")
        if isinstance(cameras, list):
            return len(cameras)
    except (OSError, ValueError):
        pass
    try:
        return len(json.load(open(os.path.join(r["dataset"], "rig.json")))["cameras"])
    except (OSError, ValueError, KeyError):
        return ""


def split_ate(run_dir):
    """ATE rmse (m) of the final trajectory over its keyframes and over the other frames, under the one
    alignment of eval/ (eval/ate_errors.csv, keyframes.tum's time stamps), and the number of non-keyframes."""
    try:
        keyframes = {line.split()[0] for line in open(os.path.join(run_dir, "keyframes.tum"))
                     if line.strip() and not line.startswith("#")}
        kf, other = [], []
        for e in csv.DictReader(open(os.path.join(run_dir, "eval", "ate_errors.csv"))):
            (kf if e["t_s"] in keyframes else other).append(float(e["translation_error_m"]) ** 2)
    except OSError:
        return nan, nan, 0
    rmse = lambda v: math.sqrt(sum(v) / len(v)) if v else nan
    return rmse(kf), rmse(other), len(other)


rows = []
for r in csv.DictReader(open(tsv), delimiter="\t"):
    row = dict(sequence=r["sequence"], scene=r["scene"], rig=r["rig"], config=r["config"], seed=int(r["seed"]),
               effects=r["effects"], run=r["run"], cameras=expected_cameras(r), frames="", posed="", posed_pct=nan, segments="",
               ate_pct=nan, ate_m=nan, path_m=nan, scale_pct=nan, fps=nan, run_s=nan,
               ate_pct_pre=nan, scale_pct_pre=nan, local_pct=nan, local_pct_pre=nan, ba_s=nan,
               ate_kf_m=nan, ate_nonkf_m=nan, nonkf=0,
               render_s=float(r["render_s"]) if r["render_s"] else nan, status="", warning="")
    record_path = os.path.join(runs_dir, ".batch", "runs", r["run"] + ".json")
    record = json.load(open(record_path)) if os.path.exists(record_path) else {}
    run_json = os.path.join(runs_dir, r["run"], "run.json")
    if r["render_status"] != "ok":
        row["status"] = "render failed"
    elif record.get("status") == "failed":
        row["status"] = "failed"
        row["warning"] = record.get("note", "")
    elif not os.path.exists(run_json):
        row["status"] = "not run"
    else:
        run = json.load(open(run_json))
        res, timing = run.get("result", {}), run.get("timing", {})
        align = run.get("config", {}).get("eval", {}).get("align", "?")
        row.update(status="ok" if align == "se3" else "eval.align=" + align,
                   cameras=len(run.get("dataset", {}).get("cameras", [])) or row["cameras"],
                   frames=res.get("frames", ""), posed=res.get("posed_frames", ""), segments=res.get("segments", ""),
                   ate_pct=num(res.get("ate_percent_of_path")), ate_m=num(res.get("ate_rmse_m")),
                   path_m=num(res.get("gt_path_length_m")), scale_pct=num(res.get("scale_error_percent")),
                   local_pct=num(res.get("local_scale_worst_percent")),
                   fps=num(timing.get("frames_per_second")), run_s=num(timing.get("seconds_total")),
                   warning=res.get("warning", ""))
        if res.get("frames"):
            row["posed_pct"] = 100.0 * res.get("posed_frames", 0) / res["frames"]
        # Before the global bundle adjustment (refine/global_ba.h): the same
        # run's trajectory as it left the odometry (and loop closure).
        ba = res.get("global_ba", {})
        if ba.get("applied") and not math.isnan(row["path_m"]) and row["path_m"] > 0:
            row["ate_pct_pre"] = 100.0 * num(ba.get("ate_rmse_m_before")) / row["path_m"]
            row["scale_pct_pre"] = num(ba.get("scale_error_percent_before"))
            row["local_pct_pre"] = num(ba.get("local_scale_worst_percent_before"))
        elif row["status"] == "ok":
            row["ate_pct_pre"], row["scale_pct_pre"] = row["ate_pct"], row["scale_pct"]
            row["local_pct_pre"] = row["local_pct"]
        row["ba_s"] = num(timing.get("global_ba_s_total"))
        row["ate_kf_m"], row["ate_nonkf_m"], row["nonkf"] = split_ate(os.path.join(runs_dir, r["run"]))
    rows.append(row)


def targets(row):
    """(posed ok, ATE ok, scale ok or None when the rig has no scale target)."""
    three = row["cameras"] == 3
    ok = row["status"] == "ok"
    posed = ok and row["posed_pct"] >= 99.0
    ate = ok and row["ate_pct"] <= (0.5 if three or row["cameras"] == 1 else 0.3)
    scale = (ok and row["scale_pct"] <= 1.0) if three else None
    return posed, ate, scale


def f(x, digits=3):
    return "" if isinstance(x, float) and math.isnan(x) else (f"{x:.{digits}f}" if isinstance(x, float) else str(x))


# per sequence (run) CSV
keys = ["sequence", "scene", "rig", "cameras", "config", "seed", "effects", "frames", "posed", "posed_pct", "segments",
        "ate_pct", "ate_m", "path_m", "scale_pct", "ate_pct_pre", "scale_pct_pre", "local_pct", "local_pct_pre",
        "ate_kf_m", "ate_nonkf_m", "fps", "run_s", "ba_s", "render_s",
        "status", "warning"]
base = e["OUT_BASE"]
with open(base + ".csv.tmp", "w", newline="") as out:
    w = csv.writer(out)
    w.writerow(["sequence", "scene", "rig", "cameras", "config", "seed", "effects", "frames", "frames_posed",
                "frames_posed_percent", "segments", "ate_percent_of_path", "ate_rmse_m", "gt_path_length_m",
                "scale_error_percent", "ate_percent_before_global_ba", "scale_error_percent_before_global_ba",
                "local_scale_worst_percent", "local_scale_worst_percent_before_global_ba",
                "ate_rmse_m_keyframes", "ate_rmse_m_non_keyframes",
                "frames_per_second", "run_seconds", "global_ba_seconds", "render_seconds", "status", "warning"])
    for row in rows:
        w.writerow([f(row[k], 4) if isinstance(row[k], float) else row[k] for k in keys])
os.replace(base + ".csv.tmp", base + ".csv")

# per rig (config)
groups = {}
for row in rows:
    groups.setdefault((row["rig"], row["config"]), []).append(row)


def stat(values, worst):
    values = [v for v in values if not math.isnan(v)]
    return (statistics.median(values), worst(values)) if values else (nan, nan)


def mw(median, worst, digits=3):
    return "-" if math.isnan(median) else f"{f(median, digits)} / {f(worst, digits)}"


rig_lines = []
total = dict(n=0, posed=0, ate=0, scale=0, scale_n=0, all=0)
for (rig, config), rs in groups.items():
    cams = sorted({r["cameras"] for r in rs if r["cameras"] != ""})
    cams_s = ",".join(map(str, cams)) if cams else "?"
    three = cams == [3]
    n = len(rs)
    failed = sum(r["status"] != "ok" for r in rs)
    t = [targets(r) for r in rs]
    posed_ok = sum(p for p, _, _ in t)
    ate_ok = sum(a for _, a, _ in t)
    scale_ok = sum(bool(s) for _, _, s in t)
    all_ok = sum(p and a and (s is None or s) for p, a, s in t)
    pm, pw = stat([r["posed_pct"] for r in rs], min)
    am, aw = stat([r["ate_pct"] for r in rs], max)
    sm, sw = stat([r["scale_pct"] for r in rs], max)
    bam, baw = stat([r["ate_pct_pre"] for r in rs], max)
    bsm, bsw = stat([r["scale_pct_pre"] for r in rs], max)
    lm, lw = stat([r["local_pct"] for r in rs], max)
    fm, _ = stat([r["fps"] for r in rs], min)
    target = ("ATE <= 0.5 %, scale <= 1 %" if three else "Sim3 ATE <= 0.5 %" if cams == [1] else "ATE <= 0.3 %")
    rig_lines.append(f"| {rig} | {config} | {cams_s} | {n} | {failed} | {mw(pm, pw, 1)} | {mw(am, aw)} | "
                     f"{mw(sm, sw)} | {mw(lm, lw, 2)} | {mw(bam, baw)} | {mw(bsm, bsw)} | {f(fm, 1) or '-'} | {target} | {posed_ok}/{n} | {ate_ok}/{n} | "
                     f"{f'{scale_ok}/{n}' if three else '-'} | {all_ok}/{n} |")
    total["n"] += n
    total["posed"] += posed_ok
    total["ate"] += ate_ok
    total["all"] += all_ok
    if three:
        total["scale"] += scale_ok
        total["scale_n"] += n

seq_lines = []
for r in rows:
    p, a, s = targets(r)
    mark = "" if r["status"] != "ok" else ("yes" if p and a and (s is None or s) else "no")
    posed = f"{r['posed']}/{r['frames']} ({f(r['posed_pct'], 1)})" if r["frames"] != "" else ""
    seq_lines.append(f"| {r['sequence']} | {r['scene']} | {r['rig']} | {r['config']} | {r['seed']} | {r['effects']} | "
                     f"{posed} | {r['segments']} | {f(r['ate_pct'])} | {f(r['scale_pct'])} | {f(r['local_pct'], 2)} | {f(r['ate_pct_pre'])} | "
                     f"{f(r['scale_pct_pre'])} | {f(r['fps'], 1)} | {f(r['ba_s'], 1)} | "
                     f"{r['status']} | {mark} | {r['warning'].replace('|', '/')} |")

# The global bundle adjustment's effect: the same runs' ATE before and after it.
pairs = [(r["ate_pct_pre"], r["ate_pct"]) for r in rows
         if r["status"] == "ok" and not math.isnan(r["ate_pct_pre"]) and not math.isnan(r["ate_pct"]) and r["ate_pct_pre"] > 0]
global_ba_lines = []
if pairs:
    ratios = sorted(after / before for before, after in pairs)
    better = sum(after < before for before, after in pairs)
    ba_share = [r["ba_s"] / r["run_s"] for r in rows if not math.isnan(r["ba_s"]) and r["run_s"] > 0]
    global_ba_lines = [
        "## Global bundle adjustment (refine/global_ba.h)", "",
        f"ATE after / before the global BA over the {len(pairs)} runs with a pose: median "
        f"{statistics.median(ratios):.3f}, best {ratios[0]:.3f}, worst {ratios[-1]:.3f}; lower after in "
        f"{better} of {len(pairs)}. Its share of the run's wall time: median "
        f"{100 * statistics.median(ba_share):.1f} %, worst {100 * max(ba_share):.1f} %." if ba_share else "", "",
        "Local scale: the worst deviation from 1 over 50-frame windows of estimated / true distance between the "
        "window's end poses (docs/eval.md, \"Local scale\"), per run; median and worst over the rig's runs, before "
        "and after the global BA; \"within 1 %\": runs whose worst window is within 1 % after it.", "",
        "| rig | config | runs | local scale worst % before: median / worst | after: median / worst | within 1 % |",
        "|---|---|---|---|---|---|"]
    for (rig, config), rs in groups.items():
        ok = [r for r in rs if r["status"] == "ok" and not math.isnan(r["local_pct"])]
        if not ok:
            continue
        pm_, pw_ = stat([r["local_pct_pre"] for r in ok], max)
        am_, aw_ = stat([r["local_pct"] for r in ok], max)
        within = sum(r["local_pct"] <= 1.0 for r in ok)
        global_ba_lines.append(f"| {rig} | {config} | {len(ok)} | {mw(pm_, pw_, 2)} | {mw(am_, aw_, 2)} | "
                               f"{within}/{len(rs)} |")
    global_ba_lines.append("")
    split = [(r["ate_kf_m"], r["ate_nonkf_m"], r["nonkf"], r["posed"]) for r in rows
             if r["status"] == "ok" and r["nonkf"] >= 10 and r["ate_kf_m"] > 0]
    if split:
        ratios = sorted(o / k for k, o, _, _ in split)
        share = statistics.median(n / p for _, _, n, p in split if p)
        global_ba_lines += [
            "Non-keyframes follow their keyframe (refine_stage.h). Their ATE rmse over the keyframes' under the "
            f"same alignment, over the {len(split)} runs with at least 10 non-keyframes (median share of the posed "
            f"frames {100 * share:.0f} %): median {statistics.median(ratios):.3f}, best {ratios[0]:.3f}, "
            f"worst {ratios[-1]:.3f}. A ratio near 1 leaves nothing for re-posing them against the refined map "
            "(rig PnP) to gain.", ""]

run_sum = sum(r["run_s"] for r in rows if not math.isnan(r["run_s"]))
render_sum = sum(r["render_s"] for r in {x["sequence"]: x for x in rows}.values() if not math.isnan(r["render_s"]))
n_seq = len({r["sequence"] for r in rows})
subset = f"; subset ONLY='{info['only']}': {n_seq} of {info['total_sequences']} sequences" if info["only"] else ""
if info["overrides"]:
    subset += f"; every config with SET='{info['overrides']}'"
monocular = e["SUITE"] == "monocular"
title = ("# Monocular suite: `mcvo run` on one-camera rigs (SUITE=monocular tools/bench_suite.sh)" if monocular
         else "# Held-out seeds: `mcvo run` on sequences nothing was tuned on (SUITE=heldout tools/bench_suite.sh)"
         if e["SUITE"] == "heldout"
         else "# Robustness suite: `mcvo run` on every sequence (tools/bench_suite.sh)")
measures = (
    "One-camera rigs run at an arbitrary scale (run.json result.scale = \"arbitrary\"), so every run's evaluation "
    "aligns with a similarity (result.alignment = sim3, chosen by the run; the config keeps eval.align se3) about "
    "the camera centre. ATE: rmse over the posed frames after that Sim3 alignment, % of the ground-truth path over "
    "those frames; there is no scale error. frames/s: wall clock of the run (not deterministic). Targets: frames "
    "posed >= 99 %; Sim3 ATE <= 0.5 %. Medians and worsts are over the runs that have the value; a failed run, "
    "or one without a pose, counts against every target." if monocular else
    "ATE: rmse over the posed frames after SE3 alignment (no scale fitted), % of the ground-truth path over those "
    "frames. Scale error: 100 |1/s - 1| of the Sim3 fit. frames/s: wall clock of the run (not deterministic). "
    "Targets: frames posed >= 99 %; 3-camera rigs ATE <= 0.5 % and scale error <= 1 %; other rigs (2, 4, 5, 6 "
    "cameras) ATE <= 0.3 %. Medians and worsts are over the runs that have the value; a failed run, or one "
    "without a pose, counts against every target.")
lines = [
    title, "",
    f"{info['date']}, {info['version']}, commit {info['commit']}. Machine: nproc = {info['nproc']} ({info['cpu']}). "
    f"{n_seq} sequences of {info['frames']} frames, {len(rows)} runs{subset}.", "",
    f"Wall time: rendering {info['render_s']:.0f} s in this invocation ({info['rendered']} sequences rendered, "
    f"{info['cached']} cached, {info['render_failed']} failed; the recorded render time of these sequences is "
    f"{render_sum:.0f} s), `mcvo synth --threads 2`, one at a time. Runs: `mcvo batch --jobs 1`, 2 threads per run, "
    f"--force (every run again), {info['batch_s']:.0f} s in this invocation (exit {info['batch_rc']}); "
    f"the runs themselves took {run_sum:.0f} s ({run_sum / 60:.1f} min; run.json timing.seconds_total).", "",
    measures, "",
    "## Per rig and config", "",
    "| rig | config | cameras | sequences | failed | frames posed % median / worst | ATE % median / worst | "
    "scale error % median / worst | local scale worst % median / worst | before global BA: ATE % | before global BA: scale error % | frames/s median | "
    "target | posed >= 99 % | ATE target | scale target | all targets |",
    "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    *rig_lines,
    f"| all | | | {total['n']} | | | | | | | | | | {total['posed']}/{total['n']} | {total['ate']}/{total['n']} | "
    f"{total['scale']}/{total['scale_n']} | {total['all']}/{total['n']} |", "",
    *global_ba_lines,
    "## Per sequence", "",
    "| sequence | scene | rig | config | seed | effects | frames posed (%) | segments | ATE % | scale error % | "
    "local scale worst % | ATE % before global BA | scale error % before global BA | frames/s | global BA s | status | targets met | "
    "warning |",
    "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    *seq_lines,
]
with open(base + ".md.tmp", "w") as out:
    out.write("\n".join(lines) + "\n")
os.replace(base + ".md.tmp", base + ".md")
print("\n".join(lines))
PY
