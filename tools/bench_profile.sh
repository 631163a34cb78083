#!/usr/bin/env bash
# CPU profile (issue 58, item 1): where `mcvo run` spends its CPU, stage by
# stage, per frame and per megapixel of input image. Writes
# results/profile.md and results/profile.csv and prints the tables.
#
#   tools/bench_profile.sh [MCVO] [SCRATCH]
#       defaults: build/mcvo, ${TMPDIR:-/tmp}/mcvo_bench_profile
#   env DATA            the real samples' folder (default ../shared/data/real)
#   env RENDER_THREADS  threads of the two renders (default 2; not profiled)
#   env REPEATS         runs without perf per input, their medians taken (default 3)
#   env KEEP_PERF_DATA  1: keep each perf.data in SCRATCH (default: removed once folded)
#
# Inputs, one `mcvo run` at a time (INPUTS below):
#   kitti06_stereo, kitti01_stereo (2 cameras, 1226x370 / 1241x376, 51 frames)
#   and euroc_v101_static (EuRoC layout, 2 cameras 752x480, 40 frames) from
#   DATA, with the built-in defaults (no --config);
#   stereo_half: `mcvo synth --preset stereo --frames 300 --image-scale 0.5
#   --scene open --noise 2 --seed 7`, run with config/kitti360_2cam.json;
#   kitti360_full: `mcvo synth --preset kitti360 --frames 60 --scene urban
#   --samples 1 --noise 1 --seed 13` (two 1408x376 pinholes, two 1400x1400
#   fisheyes; the data of tools/bench_throughput.sh), config/kitti360_4cam.json.
#   Every input at --threads 1; kitti06_stereo also at --threads 2.
#   The renders are made once into SCRATCH and reused while they exist
#   (SCRATCH/*/.bench_profile_synth: the arguments they were made with).
#
# Per input and thread count, after reading the input's files once (page cache):
#   1. `mcvo run` alone under seconds_of (tools/bench_common.sh), REPEATS
#      times: the medians of its wall clock and CPU seconds (user + system,
#      all threads). These CPU seconds are the ones the tables divide up: the
#      cost without the profiler.
#   2. the same run under `perf record -e cpu-clock -F 499 --call-graph
#      dwarf,16384` (a small python wrapper between perf and mcvo records
#      mcvo's pid and its own user + system seconds under perf); the two
#      trajectories are compared byte for byte.
#   3. `perf script --no-inline`: every sample of mcvo's process (all its
#      threads; kernel frames too where perf_event_paranoid allows) with its
#      call stack, folded here in python: each sample lands in exactly one
#      stage, the innermost frame (from the leaf up) that a stage rule
#      matches; when several rules match one frame the first in STAGE_RULES
#      wins; a sample no frame of which matches is 'other'. So decoding is
#      'decode' wherever it runs (the frontend, the loop stage's reading of
#      keyframe images), a pyramid is 'pyramid' wherever it is built (the
#      tracker's, the cross-camera matcher's of a warped image); the .md says
#      under which outer stage they ran. Samples no rule places are placed by
#      time: those of OpenCV's TBB workers and Ceres' pool (no caller on their
#      stacks) take the stage of the nearest sample of a thread inside that
#      library's dispatcher; stacks cut short, the stage of the same thread's
#      nearest sample (POOLS, CUT_* below; the .md says how much). Shares are
#      weighted by the samples' periods (CPU nanoseconds of cpu-clock).
# Tables: per stage, % of samples; CPU s per frame = share x step 1's CPU
# seconds / frames; CPU ms per camera-frame per Mpx = that in ms / (the sum of
# the run's cameras' megapixels), the cost of one megapixel of input image;
# beside it the run's own stage timings from run.json's timing section
# (wall seconds, per frame; docs/run-outputs.md), where a stage has one.
# Start-up, hashing, outputs and the global BA happen once per run: their
# per-frame figures fall with longer sequences.
set -euo pipefail
cd "$(dirname "$0")/.."
COMMAND_LINE="tools/bench_profile.sh${*:+ $*}"
MCVO=${1:-build/mcvo}
SCRATCH=${2:-${TMPDIR:-/tmp}/mcvo_bench_profile}
DATA=${DATA:-../shared/data/real}
RENDER_THREADS=${RENDER_THREADS:-2}
REPEATS=${REPEATS:-3}
OUT_MD=results/profile.md
OUT_CSV=results/profile.csv
PERF_FREQ=499
PERF_STACK=16384
PY=$(command -v /usr/bin/python3 || command -v python3)
mkdir -p "$SCRATCH"

# perf present and allowed to sample this user's processes: else one line, exit 1.
PERF=$(command -v perf || true)
if [[ -z $PERF ]]; then
  echo "bench_profile.sh: perf is not installed (Debian package linux-perf; make deps installs it)" >&2
  exit 1
fi
PARANOID=$(cat /proc/sys/kernel/perf_event_paranoid 2>/dev/null || echo 2)
EVENT="cpu-clock"
if [[ $(id -u) -ne 0 ]]; then
  if (( PARANOID > 2 )); then
    echo "bench_profile.sh: kernel.perf_event_paranoid is $PARANOID: perf may not profile a user's processes (sudo sysctl kernel.perf_event_paranoid=2, or run as root)" >&2
    exit 1
  fi
  (( PARANOID > 1 )) && EVENT="cpu-clock:u"  # user space only: kernel frames are not sampled
fi
if ! "$PERF" record -q -e "$EVENT" -F "$PERF_FREQ" --call-graph "dwarf,$PERF_STACK" -o "$SCRATCH/probe.data" \
    -- true > "$SCRATCH/probe.log" 2>&1; then
  echo "bench_profile.sh: perf record fails here (perf_event_paranoid $PARANOID): $(grep -m1 . "$SCRATCH/probe.log")" >&2
  exit 1
fi
rm -f "$SCRATCH/probe.data"
[[ -d $DATA ]] || { echo "bench_profile.sh: no sample folder $DATA" >&2; exit 1; }

# shellcheck source=tools/bench_common.sh
source tools/bench_common.sh  # seconds_of

# name|dataset|config (default: none)|threads
INPUTS=(
  "kitti06_stereo|$DATA/kitti06_stereo|default|1 2"
  "kitti01_stereo|$DATA/kitti01_stereo|default|1"
  "euroc_v101_static|$DATA/euroc_v101_static|default|1"
  "stereo_half|$SCRATCH/stereo_half|config/kitti360_2cam.json|1"
  "kitti360_full|$SCRATCH/kitti360_full|config/kitti360_4cam.json|1"
)

render() {  # folder synth-args...: renders unless the folder holds a render of exactly these arguments
  local seq=$1
  shift
  if [[ ! -f "$seq/frames.csv" || "$(cat "$seq/.bench_profile_synth" 2>/dev/null)" != "$*" ]]; then
    echo "rendering $seq ..." >&2
    "$MCVO" synth "$@" --threads "$RENDER_THREADS" --force --out "$seq" >&2
    echo "$*" > "$seq/.bench_profile_synth"
  fi
}
render "$SCRATCH/stereo_half" --preset stereo --frames 300 --image-scale 0.5 --scene open --noise 2 --seed 7
render "$SCRATCH/kitti360_full" --preset kitti360 --frames 60 --scene urban --samples 1 --noise 1 --seed 13

# Between perf and mcvo: runs the command, writes "pid wall user sys" of it.
WRAPPER="$SCRATCH/rusage_wrapper.py"
cat > "$WRAPPER" <<'PY'
import resource, subprocess, sys, time
out, log, cmd = sys.argv[1], sys.argv[2], sys.argv[3:]
start = time.monotonic()
with open(log, "w") as f:
    p = subprocess.Popen(cmd, stdout=f, stderr=subprocess.STDOUT)
    rc = p.wait()
wall = time.monotonic() - start
u = resource.getrusage(resource.RUSAGE_CHILDREN)
with open(out, "w") as f:
    f.write(f"{p.pid} {wall:.3f} {u.ru_utime:.3f} {u.ru_stime:.3f}\n")
sys.exit(rc)
PY

# perf script's text -> the samples of one pid, folded: JSON lines {"stack": [[sym, dso], ...] (leaf first),
# "samples": [[time_s, period, tid], ...]}, one line per distinct stack; last, the count of other pids' samples.
FOLD="$SCRATCH/fold.py"
cat > "$FOLD" <<'PY'
import collections, json, os, sys
script, pid, out = sys.argv[1], sys.argv[2], sys.argv[3]
folded = collections.OrderedDict()
others = 0
def flush(head, frames):
    global others
    if head is None:
        return
    fields = head.split()
    if fields[0].split("/")[0] != pid:
        others += 1
        return
    tid = fields[0].split("/")[-1]
    when = next((float(x[:-1]) for x in fields[1:] if x.endswith(":")), 0.0)
    period = int(fields[-1]) if fields[-1].isdigit() else 1
    folded.setdefault(tuple(tuple(f) for f in frames), []).append([when, period, tid])
head, frames = None, []
with open(script, errors="replace") as f:
    for line in f:
        if not line.strip():
            flush(head, frames)
            head, frames = None, []
        elif not line.startswith("\t"):  # a sample's line (the pid right-aligned); its frames start with a tab
            flush(head, frames)
            head, frames = line, []
        else:
            addr, _, rest = line.strip().partition(" ")
            sym, _, dso = rest.rpartition(" (")
            frames.append([sym.strip() or "[unknown]", os.path.basename(dso.rstrip(")"))])
flush(head, frames)
with open(out, "w") as f:
    for stack, samples in folded.items():
        f.write(json.dumps({"stack": stack, "samples": samples}) + "\n")
    f.write(json.dumps({"other_pid_samples": others}) + "\n")
PY

LOAD_BEFORE=$(cut -d' ' -f1-3 /proc/loadavg)
RUNS="$SCRATCH/runs.tsv"  # id name dataset config threads frames wall cpu
: > "$RUNS"
for entry in "${INPUTS[@]}"; do
  IFS='|' read -r name dataset config threads_list <<< "$entry"
  [[ -d $dataset ]] || { echo "bench_profile.sh: no input $dataset" >&2; exit 1; }
  "$MCVO" info --dataset "$dataset" > "$SCRATCH/info_$name.txt"
  find "$dataset" -type f -exec cat {} + > /dev/null  # page cache: no run pays for the disk
  args=()
  [[ $config != default ]] && args=(--config "$config")
  for threads in $threads_list; do
    id="${name}_t$threads"
    times=()
    for ((k = 0; k < REPEATS; ++k)); do
      times+=("$(seconds_of "$MCVO" run --dataset "$dataset" "${args[@]}" --threads "$threads" --force \
        --out "$SCRATCH/plain_$id")")
    done
    t=$(printf '%s\n' "${times[@]}" | "$PY" -c "import statistics, sys
rows = [l.split() for l in sys.stdin if l.strip()]
print(statistics.median(float(r[0]) for r in rows), statistics.median(float(r[1]) for r in rows))")
    echo "$id: ${times[*]} (wall, cpu s without perf; medians $t); profiling ..." >&2
    "$PERF" record -e "$EVENT" -F "$PERF_FREQ" --call-graph "dwarf,$PERF_STACK" -o "$SCRATCH/$id.perf.data" -- \
      "$PY" "$WRAPPER" "$SCRATCH/$id.rusage" "$SCRATCH/$id.log" \
      "$MCVO" run --dataset "$dataset" "${args[@]}" --threads "$threads" --force --out "$SCRATCH/run_$id" \
      2> "$SCRATCH/$id.record.log" || { cat "$SCRATCH/$id.record.log" "$SCRATCH/$id.log" >&2; exit 1; }
    "$PERF" script -i "$SCRATCH/$id.perf.data" -F pid,tid,time,period,ip,sym,dso --no-inline \
      > "$SCRATCH/$id.script.txt" 2> "$SCRATCH/$id.script.log"
    "$PERF" evlist -i "$SCRATCH/$id.perf.data" 2> /dev/null | head -1 > "$SCRATCH/$id.event"
    "$PY" "$FOLD" "$SCRATCH/$id.script.txt" "$(cut -d' ' -f1 "$SCRATCH/$id.rusage")" "$SCRATCH/$id.stacks.jsonl"
    rm -f "$SCRATCH/$id.script.txt"
    [[ ${KEEP_PERF_DATA:-0} == 1 ]] || rm -f "$SCRATCH/$id.perf.data"
    frames=$("$PY" -c "import json,sys; print(json.load(open(sys.argv[1]))['result']['frames'])" \
      "$SCRATCH/plain_$id/run.json")
    read -r wall cpu <<< "$t"
    printf '%s\t%s\t%s\t%s\t%s\t%s\t%s\t%s\n' "$id" "$name" "$dataset" "$config" "$threads" "$frames" "$wall" "$cpu" \
      >> "$RUNS"
  done
done
LOAD_AFTER=$(cut -d' ' -f1-3 /proc/loadavg)
PERF_VERSION=$("$PERF" --version 2>/dev/null || echo perf)

"$PY" - "$MCVO" "$SCRATCH" "$OUT_CSV" "$COMMAND_LINE" "$LOAD_BEFORE" "$LOAD_AFTER" "$PERF_VERSION" "$EVENT" \
  "$PERF_FREQ" "$PERF_STACK" "$PARANOID" "$REPEATS" > "$OUT_MD" <<'PY'
import collections, csv, datetime, filecmp, json, os, re, subprocess, sys
(mcvo, scratch, out_csv, command_line, load_before, load_after, perf_version, event, freq, stack_bytes,
 paranoid, repeats) = sys.argv[1:]

# Stage rules: (stage, frame regex, condition). A frame is "SYMBOL [DSO]" (perf's demangled symbol, the
# file's base name). Condition: None; ("parent", regex): the frame directly above (the caller) matches;
# ("within", regex): some frame above matches; CLAIMS: this frame anywhere on the stack takes the sample,
# whatever is inside it. Listed in the tables' order; on one frame the first match wins.
M = r"^(?:[\w:]+ )?mcvo::"  # a function of mcvo (an optional return type before it: templates)
E = r"(?= \[[^\]]*\]$)"  # the end of the symbol
NS = r"(?:[\w:]|\(anonymous namespace\))*"  # a namespace path, anonymous ones included
CLAIMS = ("claims", None)  # the rule's stage takes the whole sample when the frame is anywhere on the stack
STAGE_RULES = [
    ("start-up", [
        (r"\[ld-linux[^\]]*\]$", None),  # the dynamic linker: loading, relocation, lazy binding
        (r"^_dl_", None),
        # constructors and loaders: everything inside them is start-up (the warp maps, masks, images read)
        (M + r"(MultiCameraTracker::MultiCameraTracker|CameraTracker::CameraTracker|FrameSource::FrameSource)", CLAIMS),
        (M + r"CrossCameraMatcher::CrossCameraMatcher", CLAIMS),  # the warp maps
        (M + r"Vocabulary::Load", CLAIMS),
        (M + r"(LoopCloser::LoopCloser|pipeline_internal::RunLoopStage::RunLoopStage|pipeline_internal::MakeLoopCloser)", CLAIMS),
        (M + r"(OpenRunDataset|OpenDataset|Read\w*Dataset|ReadFrameTable|ParseFrameTable|ReadRig|ReadEuroc\w*)", CLAIMS),
        (M + r"(PipelineOptions|LoadConfig|ParseConfig|ReadConfig)", CLAIMS),
        (r"^_GLOBAL__sub_I|^call_init|^_init$", None),
    ]),
    ("decode", [
        (M + r"(ReadImageFile|DecodePng|DecodeContainerImage|DecodeColmapColorImage|GreyOfDecodedImage|ReadImageHeader)", None),
        (M + r"FrameStream::", None),
        (r"^cv::(imread|imdecode)", None),
        (r"^libdeflate_", None),
    ]),
    ("CLAHE", [
        (r"CLAHE", None),
        # OpenCV's CLAHE is a local symbol ([unknown] without debug symbols): the tracker calls nothing
        # else of libopencv_imgproc directly.
        (r"^\[unknown\] \[libopencv_imgproc", ("parent", M + r"CameraTracker::Impl::Track" + E)),
    ]),
    ("pyramid", [(r"^cv::buildOpticalFlowPyramid", None)]),
    ("LK tracking", [(M + r"CameraTracker::Impl::TrackLk", None)]),
    ("RANSAC", [(M + r"(CameraTracker::Impl::RejectByRansac|RansacRelativePoseInliers)", None)]),
    ("anchor check", [(M + r"(CameraTracker::Impl::RefineByAnchor|AlignPatch|MakePatchAnchor|PatchAligner)", None)]),
    ("detection", [
        (M + r"CameraTracker::Impl::(Detect|AddNewFeatures)", None),
        (M + NS + r"Detector\w*::", None),
        (M + r"(SelectFeatures|DecodeCellLogits|" + NS + r"KeypointNet)", None),
    ]),
    ("cross-camera matching", [(M + r"CrossCameraMatcher::", None)]),
    ("frontend other", [(M + r"(CameraTracker::|MultiCameraTracker::|FrameSource::)", None)]),
    ("initializer", [
        (M + r"(Initializer::|InitialiseFromOverlap|initializer_internal::)", None),
        (M + r"Estimator::Impl::(StartFromInitialization|WindowFromInitialization)", None),
    ]),
    ("PnP", [
        (M + r"Estimator::Impl::PoseNewFrame", None),
        (M + r"SolveRigPnp", ("within", M + r"Estimator::")),
    ]),
    ("window BA", [
        (M + r"backend_internal::WindowProblem::(Solve|Add\w*)", None),
        (M + r"Estimator::Impl::Solve" + E, None),
        (M + r"backend_internal::LandmarkWindow::RemoveOutliers", None),
    ]),
    ("marginalisation", [
        (M + r"(backend_internal::WindowProblem::MarginalizeOldest|Estimator::Impl::MarginalizeOldest|Marginalizer::)", None),
    ]),
    ("scale correction", [
        (M + r"(backend_internal::WindowScaleCorrector::|ScaleFilter::|backend_internal::WindowProblem::RescalePriorPositions)", None),
    ]),
    ("backend other", [(M + r"(Estimator::|backend_internal::|pipeline_internal::OdometryStage::|ToObservations)", None)]),
    ("relocalisation, reverse pass", [
        (M + r"(ReversePass::|pipeline_internal::RelocaliseSegments|LoopCloser::Relocalise|LoopCloser::Impl::Relocalise)", None),
    ]),
    ("loop features", [
        (M + r"LoopCloser::(Impl::)?(ExtractImageFeatures|ExtractCamera|Extract\b|Prepare)", None),
        (M + r"pipeline_internal::(LoopImageCache::|ToLoopKeyframe)", None),
        (M + r"loop_internal::(DescribeOriented|IntensityCentroidAngle|Orb\w*)", None),
    ]),
    ("loop detection, links, pose graph", [
        (M + r"(LoopCloser::|Vocabulary::|OptimizePoseGraph|FindCrossCameraLinks|loop_internal::)", None),
        (M + r"\(anonymous namespace\)::LinkSearch::", None),
        (M + r"pipeline_internal::(CloseLoops|ApplyLoopCorrection|RunLoopStage::)", None),
    ]),
    ("global BA", [
        (M + r"(RunGlobalBundleAdjustment|FuseLoopLandmarks|refine_internal::|pipeline_internal::RefineGlobally|pipeline_internal::BuildSparseMap)", None),
        (M + r"\(anonymous namespace\)::GlobalProblem", None),
    ]),
    ("COLMAP export", [
        (M + r"(" + NS + r"Colmap\w*|colmap_internal::|pipeline_internal::SampleKeyframeColors)", None),
    ]),
    ("outputs: eval, report, files", [
        (M + r"(pipeline_internal::WriteRunOutputs|WriteReports|RenderReport\w*|report_internal::|EvaluateTrajectory|WriteEvalOutputs|EvalResultTo\w*|ComputeLocalScale|eval_internal::)", None),
        (M + r"(WriteTrajectory|WriteFileAtomic|AtomicFileWriter::|OutputFolder::|WriteFrameTable|WritePipelineOptions|WriteRig|pipeline_internal::\w*Csv)", None),
    ]),
    ("hashing, input checks", [
        (M + r"(Sha256|ExecutableSha256|" + NS + r"Hash(RunInputs|DatasetContent)|" + NS + r"(StampRunFiles|CheckRunFilesUnchanged))", None),
        (r"^SHA256_", None),
    ]),
]
POOL_WORK, POOL_IDLE = "thread pool work, caller not found", "thread pools: spin, wait"
STAGES = [s for s, _ in STAGE_RULES] + [POOL_WORK, POOL_IDLE, "other"]
# Stages whose work is done once per camera image: their ms per Mpx is a pixel cost.
PIXEL_STAGES = ["decode", "CLAHE", "pyramid", "LK tracking", "detection", "anchor check", "cross-camera matching"]
FRONTEND = STAGES[STAGES.index("decode"):STAGES.index("frontend other") + 1]
BACKEND = ["initializer", "PnP", "window BA", "marginalisation", "scale correction", "backend other"]
LOOP = ["relocalisation, reverse pass", "loop features", "loop detection, links, pose graph"]
ONCE = ["start-up", "global BA", "COLMAP export", "outputs: eval, report, files", "hashing, input checks"]
COMPILED = [(stage, re.compile(rx), (cond[0], re.compile(cond[1])) if cond and cond[1] else None)
            for stage, rules in STAGE_RULES for rx, cond in rules if cond != CLAIMS]
CLAIMING = [(stage, re.compile(rx)) for stage, rules in STAGE_RULES for rx, cond in rules if cond == CLAIMS]
ROOTS = re.compile(r"^(_start|clone3?|start_thread|__clone\w*|_dl_start\w*)$")

def frame_text(f):
    return f"{f[0]} [{f[1]}]"

def stage_of_frame(texts, i):
    for stage, rx, cond in COMPILED:
        if not rx.search(texts[i]):
            continue
        if cond is None:
            return stage
        kind, crx = cond
        above = texts[i + 1:i + 2] if kind == "parent" else texts[i + 1:]
        if any(crx.search(t) for t in above):
            return stage
    return None

def stages_of(stack):  # -> (innermost stage, the next different stage outwards or None, index)
    texts = [frame_text(f) for f in stack]
    for i, t in enumerate(texts):
        for stage, rx in CLAIMING:
            if rx.search(t):
                return stage, None, i
    found = []
    for i in range(len(texts)):
        s = stage_of_frame(texts, i)
        if s is not None and (not found or found[-1][0] != s):
            found.append((s, i))
            if len(found) == 2:
                break
    if not found:
        return "other", None, None
    return found[0][0], (found[1][0] if len(found) > 1 else None), found[0][1]

# Threads of the libraries' pools (OpenCV's TBB workers, Ceres' thread pool) have no caller on their stacks.
# family: (a frame of the pool, its dispatcher on the calling thread's stack). A pool sample goes to the
# stage of the nearest sample (in time, within POOL_WINDOW_S) of another thread inside that dispatcher whose
# body is in the same library; a stack cut short (by the copy's size, or an unwinding failure) goes to the
# stage of the nearest sample of the same thread (within CUT_WINDOW_S) that has a stage and the cut stack's
# outermost frame of a known file (e.g. "[unknown] [libopencv_features2d...]", "cv::resize [...]"); failing
# that (a stack of one libc frame, malloc, memset: the unwinder stopped at once), to the stage of the same
# thread's nearest sample with a stage within CUT_TIME_S (2.5 sample intervals at 499 Hz).
POOLS = {"OpenCV": (re.compile(r"\[libtbb[^\]]*\]$"), re.compile(r"^cv::parallel_for_")),
         "Ceres": (re.compile(r"\[libceres[^\]]*\]$"), re.compile(r"^ceres::internal::(ParallelFor|ParallelInvoke)"))}
POOL_WINDOW_S, CUT_WINDOW_S, CUT_TIME_S = 0.010, 0.020, 0.005
MCVO_FRAME = re.compile(M + r"|\[mcvo[^\]]*\]$")

def library(dso):  # libopencv_imgproc.so.4.6.0 -> libopencv_imgproc
    return dso.split(".so")[0]

def pool_of(texts, stack):  # -> (family, body library or None for idle) of a pool thread's sample, else None
    if any(MCVO_FRAME.search(t) for t in texts) or not stack or not ROOTS.match(stack[-1][0]):
        return None
    for family, (frame_rx, _) in POOLS.items():
        if any(frame_rx.search(t) for t in texts):
            if family == "OpenCV":
                libs = [library(d) for _, d in stack if d.startswith("libopencv_")]
                body = next((l for l in libs if l != "libopencv_core"), libs[0] if libs else None)
            else:
                body = "libceres"
            return family, body
    return None

def dispatch_of(texts, stack):  # -> (family, body library) when the sample is inside a pool's dispatcher
    for family, (_, disp_rx) in POOLS.items():
        for i, t in enumerate(texts):
            if disp_rx.search(t):
                caller = stack[i + 1][1] if i + 1 < len(stack) else stack[i][1]
                return family, ("libceres" if family == "Ceres" else library(caller))
    return None

def nearest(index, key, when, window):
    import bisect
    entries = index.get(key)
    if not entries:
        return None
    times = [e[0] for e in entries]
    k = bisect.bisect_left(times, when)
    best = None
    for j in (k - 1, k):
        if 0 <= j < len(entries) and abs(entries[j][0] - when) <= window:
            if best is None or abs(entries[j][0] - when) < abs(best[0] - when):
                best = entries[j]
    return best[1] if best else None

def attribute(path):  # the folded samples of one run -> stage periods and the notes' figures
    recs, other_pid = [], 0
    for l in open(path):
        rec = json.loads(l)
        if "stack" in rec:
            recs.append(rec)
        else:
            other_pid = rec.get("other_pid_samples", 0)
    period = collections.Counter()
    nested = collections.defaultdict(collections.Counter)  # stage -> outer stage -> period
    other_frames = collections.Counter()
    startup = collections.Counter()  # start-up's part -> period
    pool_threads = 0  # the period of samples on the libraries' pool threads
    dispatch = collections.defaultdict(list)   # (family, body) -> [(time, stage)]
    pending_pool, pending_cut = [], []
    wanted_cut = set()
    n = truncated = total = 0
    staged = []
    for rec in recs:
        stack = [tuple(f) for f in rec["stack"]]
        texts = [frame_text(f) for f in stack]
        stage, outer, _ = stages_of(stack)
        cut = not stack or not ROOTS.match(stack[-1][0])
        for when, p, tid in rec["samples"]:
            n += 1
            total += p
            truncated += cut
        if stage != "other":
            staged.append((stack, stage, rec["samples"]))
            d = dispatch_of(texts, stack)
            if d:
                for when, p, tid in rec["samples"]:
                    dispatch[d].append((when, stage))
            for when, p, tid in rec["samples"]:
                period[stage] += p
                nested[stage][outer or "-"] += p
            if stage == "start-up":
                startup[startup_part(stack)] += sum(p for _, p, _ in rec["samples"])
            continue
        pool = pool_of(texts, stack)
        if pool:
            pending_pool.append((pool, stack, rec["samples"]))
        elif cut and any(f[1] != "[unknown]" for f in stack):
            key = next(frame_text(f) for f in reversed(stack) if f[1] != "[unknown]")
            wanted_cut.add(key)
            pending_cut.append((key, stack, rec["samples"]))
        else:
            pending_pool.append((None, stack, rec["samples"]))
    for v in dispatch.values():
        v.sort()
    cut_index = collections.defaultdict(list)  # (tid, function) -> [(time, stage)]
    for stack, stage, samples in staged:
        for key in wanted_cut.intersection(frame_text(f) for f in stack):
            for when, p, tid in samples:
                cut_index[(tid, key)].append((when, stage))
    for v in cut_index.values():
        v.sort()
    time_index = collections.defaultdict(list)  # tid -> [(time, stage)] of every sample with a stage
    for stack, stage, samples in staged:
        for when, p, tid in samples:
            time_index[tid].append((when, stage))
    for v in time_index.values():
        v.sort()
    by_pool = by_cut = by_time = 0
    def other(stack, p):
        period["other"] += p
        nested["other"]["-"] += p
        where = next((f for f in stack if MCVO_FRAME.search(frame_text(f))), stack[0] if stack else ("(empty)", "-"))
        other_frames[f"{where[0][:90]} [{where[1]}]"] += p
    for pool, stack, samples in pending_pool:
        for when, p, tid in samples:
            if pool is None:
                other(stack, p)
                continue
            pool_threads += p
            stage = nearest(dispatch, pool, when, POOL_WINDOW_S) if pool[1] else None
            if stage is None:
                stage = POOL_WORK if pool[1] else POOL_IDLE
            else:
                by_pool += p
            period[stage] += p
            nested[stage][f"{pool[0]} pool thread"] += p
    for key, stack, samples in pending_cut:
        for when, p, tid in samples:
            stage, how = nearest(cut_index, (tid, key), when, CUT_WINDOW_S), "cut-short stack"
            if stage is None:
                stage, how = nearest(time_index, tid, when, CUT_TIME_S), "cut-short stack, by time"
            if stage is None:
                other(stack, p)
            else:
                by_cut += p
                by_time += p if how.endswith("by time") else 0
                period[stage] += p
                nested[stage][how] += p
    return {"period": period, "nested": nested, "other_frames": other_frames, "samples": n,
            "truncated": truncated, "period_total": total, "by_pool": by_pool, "by_cut": by_cut, "by_time": by_time,
            "startup": startup, "pool_threads": pool_threads,
            "other_pid_samples": other_pid}

# Start-up's parts, for its note: the first whose frame is on the sample's stack.
STARTUP_PARTS = [("vocabulary", re.compile(M + r"Vocabulary::Load")),
                 ("warp maps", re.compile(M + r"CrossCameraMatcher::CrossCameraMatcher")),
                 ("bearing grids", re.compile(M + r"UnitBearingGrid")),  # every pixel unprojected
                 ("trackers", re.compile(M + r"(MultiCameraTracker::MultiCameraTracker|CameraTracker::CameraTracker|FrameSource::FrameSource)")),
                 ("loop closer", re.compile(M + r"(LoopCloser::LoopCloser|pipeline_internal::RunLoopStage::RunLoopStage|pipeline_internal::MakeLoopCloser)")),
                 ("dataset index, config", re.compile(M + r"(OpenRunDataset|OpenDataset|Read\w*Dataset|ReadFrameTable|ParseFrameTable|ReadRig|ReadEuroc|PipelineOptions|LoadConfig|ParseConfig|ReadConfig)")),
                 ("dynamic linking", re.compile(r"\[ld-linux[^\]]*\]$|^_dl_")),
                 ("static initialisers", re.compile(r"^_GLOBAL__sub_I|^call_init|^_init "))]

def startup_part(stack):
    texts = [frame_text(f) for f in stack]
    for name, rx in STARTUP_PARTS:
        if any(rx.search(t) for t in texts):
            return name
    return "rest"

def cameras_of(info_path, names):  # -> [(name, width, height)] of the run's cameras
    text = open(info_path).read()
    sizes = {}
    for m in re.finditer(r"^camera \d+: (\S+)\n\s+model\s+[^,]+, (\d+) x (\d+) px", text, re.M):
        sizes[m.group(1)] = (int(m.group(2)), int(m.group(3)))
    return [(n, *sizes[n]) for n in names]

def size_text(cams):
    groups = collections.OrderedDict()
    for _, w, h in cams:
        groups[f"{w}x{h}"] = groups.get(f"{w}x{h}", 0) + 1
    return " + ".join(f"{n} x {s}" for s, n in groups.items())

def timing_of(run_json):  # stage -> wall s per frame from run.json's timing, and the whole run's
    d = json.load(open(run_json))
    t, r = d.get("timing", {}), d["result"]
    frames, kf = r["frames"], r.get("keyframes", 0)
    fs = t.get("frontend_stages_s", {})
    out = {}
    def put(stage, value):
        if value is not None:
            out[stage] = out.get(stage, 0.0) + value
    for stage, key in [("decode", "decode"), ("CLAHE", "clahe"), ("pyramid", "pyramid"), ("LK tracking", "lk"),
                       ("RANSAC", "ransac"), ("anchor check", "anchor"), ("detection", "detection"),
                       ("detection", "selection"), ("cross-camera matching", "cross_camera")]:
        put(stage, fs.get(key))
    for stage, key in [("initializer", "initializer_s"), ("PnP", "pnp_s"), ("window BA", "ba_s"),
                       ("marginalisation", "marginalization_s"), ("scale correction", "scale_correction_s")]:
        put(stage, t.get(key))
    per_kf = lambda key: t[key] * kf / frames if key in t and frames else None
    per_run = lambda key: t[key] / frames if key in t and frames else None
    put("loop features", per_kf("loop_image_read_s_per_keyframe"))
    put("loop features", per_kf("loop_features_s_per_keyframe"))
    put("loop features", per_kf("loop_features_in_odometry_s_per_keyframe"))
    put("loop detection, links, pose graph", per_kf("loop_query_s_per_keyframe"))
    put("loop detection, links, pose graph", per_kf("loop_verification_s_per_keyframe"))
    put("loop detection, links, pose graph", per_run("pose_graph_s_total"))
    put("loop detection, links, pose graph", per_run("cross_camera_links_s_total"))
    put("relocalisation, reverse pass", per_run("reverse_pass_s_total"))
    put("global BA", per_run("global_ba_s_total"))
    put("COLMAP export", per_run("colmap_export_s_total"))
    whole = {"seconds_total": t.get("seconds_total"), "frontend_s": t.get("frontend_s"),
             "track_wall": fs.get("track_wall"), "backend_s": t.get("backend_s"),
             "odometry_s_total": t.get("odometry_s_total"), "keyframes": kf}
    return out, whole

def timing_csv_check(run_dir, run_json):  # do timing.csv's means agree with run.json's?
    path = os.path.join(run_dir, "timing.csv")
    if not os.path.exists(path):
        return None
    rows = list(csv.DictReader(open(path)))
    t = json.load(open(run_json)).get("timing", {})
    worst = 0.0
    for key in ["frontend_s", "initializer_s", "pnp_s", "ba_s", "marginalization_s", "backend_s"]:
        if rows and key in rows[0] and key in t:
            mean = sum(float(r[key]) for r in rows) / len(rows)
            worst = max(worst, abs(mean - t[key]))
    return worst

runs = []
for line in open(os.path.join(scratch, "runs.tsv")):
    rid, name, dataset, config, threads, frames, wall, cpu = line.rstrip("\n").split("\t")
    r = {"id": rid, "name": name, "dataset": dataset, "config": config, "threads": int(threads),
         "frames": int(frames), "wall": float(wall), "cpu": float(cpu)}
    pid, pwall, pu, ps = open(os.path.join(scratch, rid + ".rusage")).read().split()
    r["perf_wall"], r["perf_cpu"] = float(pwall), float(pu) + float(ps)
    plain_json = os.path.join(scratch, "plain_" + rid, "run.json")
    names = json.load(open(plain_json))["dataset"]["cameras"]
    r["cams"] = cameras_of(os.path.join(scratch, f"info_{name}.txt"), names)
    r["mpx"] = sum(w * h for _, w, h in r["cams"]) / 1e6
    r["same_outputs"] = filecmp.cmp(os.path.join(scratch, "plain_" + rid, "trajectory.tum"),
                                    os.path.join(scratch, "run_" + rid, "trajectory.tum"), shallow=False)
    r["timing"], r["whole"] = timing_of(plain_json)
    r["timing_csv_diff"] = timing_csv_check(os.path.join(scratch, "plain_" + rid), plain_json)
    r["event"] = open(os.path.join(scratch, rid + ".event")).read().strip() or event
    lost = [l.strip() for l in open(os.path.join(scratch, rid + ".record.log")) if "lost" in l.lower()]
    lost += [l.strip() for l in open(os.path.join(scratch, rid + ".script.log")) if "lost" in l.lower()]
    r["lost"] = lost
    r.update(attribute(os.path.join(scratch, rid + ".stacks.jsonl")))
    r["share"] = {s: (100.0 * r["period"][s] / r["period_total"] if r["period_total"] else 0.0) for s in STAGES}
    r["sampled_cpu"] = r["period_total"] / 1e9 if r["event"].startswith(("cpu-clock", "task-clock")) else None
    runs.append(r)

def per_frame(r, stage):  # CPU s per frame of the stage
    return r["share"][stage] / 100.0 * r["cpu"] / r["frames"]

def per_mpx(r, stage):  # CPU ms per camera-frame per Mpx
    return 1000.0 * per_frame(r, stage) / r["mpx"]

def pct(r, key):  # a period total of the run as % of its samples, 1 decimal
    return round(100.0 * r[key] / r["period_total"], 1) if r["period_total"] else 0.0

def label(r):
    return f"{r['name']} t{r['threads']}"

def config_text(r):
    return "defaults" if r["config"] == "default" else r["config"]

def top(r, k=5):
    ranked = sorted(STAGES, key=lambda s: -r["share"][s])
    return [s for s in ranked[:k] if r["share"][s] > 0]

# CSV: one row per run and stage.
keys = ["input", "threads", "config", "cameras", "sizes", "mpx_per_frame", "frames", "cpu_s", "cpu_s_per_frame",
        "wall_s", "perf_cpu_s", "samples", "stage", "share_percent", "stage_cpu_s_per_frame",
        "stage_cpu_ms_per_camera_frame_per_mpx", "runjson_wall_s_per_frame"]
with open(out_csv, "w", newline="") as f:
    w = csv.writer(f)
    w.writerow(keys)
    for r in runs:
        for s in STAGES:
            tv = r["timing"].get(s)
            w.writerow([r["name"], r["threads"], config_text(r), len(r["cams"]), size_text(r["cams"]),
                        f"{r['mpx']:.6g}", r["frames"], f"{r['cpu']:.6g}", f"{r['cpu'] / r['frames']:.6g}",
                        f"{r['wall']:.6g}", f"{r['perf_cpu']:.6g}", r["samples"], s, f"{r['share'][s]:.6g}",
                        f"{per_frame(r, s):.6g}", f"{per_mpx(r, s):.6g}", "" if tv is None else f"{tv:.6g}"])

commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", "src", "include", "tools",
                        "config", "CMakeLists.txt"], capture_output=True, text=True).stdout.strip()
version = subprocess.run([mcvo, "version"], capture_output=True, text=True).stdout.split("\n")[0].strip()
model = subprocess.run(["sh", "-c", "grep -m1 'model name' /proc/cpuinfo | cut -d: -f2"], capture_output=True,
                       text=True).stdout.strip()
now = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
kernel_note = ("kernel frames included (system time is sampled too)" if not event.endswith(":u")
               else "user space only (perf_event_paranoid: kernel frames are not sampled)")

print("# CPU profile of `mcvo run`: stage by stage, per frame and per megapixel\n")
print(f"`{command_line}`\n")
print(f"{now}, {version} (`{mcvo}`), repository commit {commit}"
      f"{' (with uncommitted changes to the sources)' if dirty else ''}. Machine: {os.cpu_count()} cores "
      f"({model}), shared with other engineers' work (load average {load_before} before, {load_after} after). "
      f"{perf_version}: `perf record -e {event} -F {freq} --call-graph dwarf,{stack_bytes}`, {kernel_note}; "
      f"perf_event_paranoid {paranoid}.\n")
print(f"CPU seconds: user + system seconds of `mcvo run` alone (all its threads; tools/bench_common.sh "
      f"seconds_of), the median of {repeats} runs without the profiler; the profiled run of the same input and "
      "thread count gives the shares (the CPU it took under perf is in the summary). CPU s/frame = share x CPU "
      "seconds / frames; CPU ms per camera-frame per Mpx = that in ms over the megapixels of all the run's "
      "cameras together, what one megapixel of input image costs. The run.json column is the run's own timing "
      "(wall seconds per frame, not CPU; docs/run-outputs.md), where it has the stage: the frontend's figures "
      "are summed over the cameras, the loop stage's per keyframe times keyframes over frames, totals over "
      "frames; 'all' is its seconds_total, from the first frame on (start-up not included).\n")
print("Attribution: each sample's call stack (perf script, folded here) goes to exactly one stage: the "
      "innermost frame, from the leaf upwards, that a stage rule matches (the rules are at the end); on one "
      "frame the first stage in the table's order wins; a constructor or loader of start-up claims everything "
      "inside it. So 'decode' is every image decode wherever it runs, 'pyramid' every LK pyramid (the "
      "tracker's, and the cross-camera matcher's of the warped image), and the stage a sample would otherwise "
      "have had is listed under each table. Samples of OpenCV's TBB worker threads and of Ceres' pool have no "
      "caller on their stacks, and some stacks are cut short: those are placed by time (the rules' section "
      "says how); what cannot be placed is 'thread pool work, caller not found', 'thread pools: spin, wait' "
      "(TBB's workers waiting for work) or 'other'. Start-up, hashing, outputs and the global BA happen once "
      "per run: on these short inputs their per-frame figures are large.\n")

print("## Summary\n")
print("| input | config | cameras x size | Mpx/frame | frames | CPU s/frame t1 | t2 | under perf t1 | "
      "top 5 stages (% of CPU, t1) |")
print("|---|---|---|---|---|---|---|---|---|")
names = list(dict.fromkeys(r["name"] for r in runs))
byname = {(r["name"], r["threads"]): r for r in runs}
for name in names:
    r1 = byname.get((name, 1)) or next(r for r in runs if r["name"] == name)
    r2 = byname.get((name, 2))
    t2 = f"{r2['cpu'] / r2['frames']:.3f}" if r2 else "-"
    tops = ", ".join(f"{s} {r1['share'][s]:.1f}" for s in top(r1))
    print(f"| {name} | {config_text(r1)} | {size_text(r1['cams'])} | {r1['mpx']:.3f} | {r1['frames']} | "
          f"{r1['cpu'] / r1['frames']:.3f} | {t2} | {r1['perf_cpu'] / r1['frames']:.3f} | {tops} |")
print()

print("## Per input\n")
for r in runs:
    print(f"### {r['name']}, --threads {r['threads']}\n")
    sampled = (f", {r['sampled_cpu']:.2f} CPU s sampled ({100 * r['sampled_cpu'] / r['perf_cpu']:.0f} % of the "
               "profiled run's user + system)" if r["sampled_cpu"] else "")
    print(f"{config_text(r)}; {size_text(r['cams'])} ({r['mpx']:.3f} Mpx per frame), {r['frames']} frames, "
          f"{r['whole']['keyframes']} keyframes. Without perf: {r['cpu']:.2f} CPU s, {r['wall']:.2f} s wall "
          f"({r['cpu'] / r['frames']:.3f} CPU s/frame); under perf {r['perf_cpu']:.2f} CPU s, "
          f"{r['perf_wall']:.2f} s wall; trajectory {'identical' if r['same_outputs'] else '**different**'}. "
          f"{r['samples']} samples{sampled}. {100.0 * r['truncated'] / max(1, r['samples']):.1f} % of the samples "
          f"have a stack cut short (by the {stack_bytes}-byte copy or a failed unwind: outermost frame not a "
          f"thread's start), most with a stage frame still on them. Placed by time (below the rules): "
          f"{pct(r, 'by_pool')} % from the libraries' pool threads, {pct(r, 'by_cut') - pct(r, 'by_time'):.1f} % "
          f"cut-short stacks by their outermost frame, {pct(r, 'by_time')} % cut-short stacks by the same "
          "thread's nearest sample.\n")
    print("| stage | % of CPU | CPU s/frame | CPU ms per camera-frame per Mpx | run.json wall s/frame |")
    print("|---|---|---|---|---|")
    for s in STAGES:
        tv = r["timing"].get(s)
        print(f"| {s} | {r['share'][s]:.1f} | {per_frame(r, s):.4f} | {per_mpx(r, s):.2f} | "
              f"{'-' if tv is None else f'{tv:.4f}'} |")
    print(f"| **all** | 100.0 | {r['cpu'] / r['frames']:.4f} | {1000 * r['cpu'] / r['frames'] / r['mpx']:.2f} | "
          f"{(r['whole']['seconds_total'] or 0) / r['frames']:.4f} |")
    print()
    notes = []
    for s in ["decode", "pyramid", "loop features"]:
        tot = sum(r["nested"][s].values())
        if tot:
            parts = [f"{100.0 * p / tot:.0f} % {'with no other stage around it' if o == '-' else 'in ' + o}"
                     for o, p in r["nested"][s].most_common()]
            notes.append(f"{s}: " + ", ".join(parts))
    if r["startup"]:
        cpu_of = lambda p: p / r["period_total"] * r["cpu"]
        notes.append("start-up, CPU s per run: " + ", ".join(f"{k} {cpu_of(p):.3f}" for k, p in r["startup"].most_common()))
    w = r["whole"]
    if w["seconds_total"] is not None:
        notes.append(f"run.json: seconds_total {w['seconds_total']:.2f} s (from the first frame, without "
                     f"start-up), odometry_s_total {w['odometry_s_total']:.2f} s, frontend_s "
                     f"{w['frontend_s']:.4f} s/frame (track_wall {w['track_wall'] or 0:.4f}), backend_s "
                     f"{w['backend_s']:.4f} s/frame, all wall")
    if r["timing_csv_diff"] is not None:
        notes.append(f"timing.csv's per-frame rows average to run.json's figures (largest difference "
                     f"{r['timing_csv_diff']:.1e} s)")
    if r["other_frames"]:
        tot = sum(r["other_frames"].values())
        parts = [f"`{k}` {100.0 * p / r['period_total']:.1f} %" for k, p in r["other_frames"].most_common(4)]
        notes.append("'other', by its innermost mcvo frame (else the leaf): " + ", ".join(parts))
    if r["lost"]:
        notes.append("perf reported lost samples: " + "; ".join(r["lost"][:2]))
    for n in notes:
        print(f"- {n}.")
    print()

# What this says: every number from the data above.
print("## What this says\n")
t1 = [r for r in runs if r["threads"] == 1]
def rng(values, fmt="{:.1f}"):
    return fmt.format(min(values)) + "-" + fmt.format(max(values))
def group_share(r, group):
    return sum(r["share"][s] for s in group)
def lead(r):
    return max(STAGES, key=lambda s: r["share"][s])
leads = collections.Counter(lead(r) for r in t1)
s_lead, n_lead = leads.most_common(1)[0]
paras = []
paras.append(f"The frontend (decode to 'frontend other') takes {rng([group_share(r, FRONTEND) for r in t1])} % "
             f"of the CPU at one thread, the odometry back end (initializer to 'backend other') "
             f"{rng([group_share(r, BACKEND) for r in t1])} %, loop closure "
             f"{rng([group_share(r, LOOP) for r in t1])} %, and the once-per-run work (start-up, global BA, "
             f"COLMAP export, outputs, hashing) {rng([group_share(r, ONCE) for r in t1])} %. The largest single "
             f"stage is {s_lead} on {n_lead} of {len(t1)} inputs"
             + ("" if n_lead == len(t1) else " (" + ", ".join(f"{r['name']}: {lead(r)}" for r in t1 if lead(r) != s_lead) + ")")
             + ".")
steady, varying = [], []
for s in PIXEL_STAGES:
    vals = [per_mpx(r, s) for r in t1 if r["share"][s] > 0]
    if vals:
        ratio = max(vals) / min(vals) if min(vals) > 0 else float("inf")
        (steady if ratio < 2 else varying).append(f"{s} {rng(vals, '{:.2f}')} ms (max/min {ratio:.1f})")
big = max(t1, key=lambda r: r["mpx"])
small = min(t1, key=lambda r: r["mpx"])
whole_mpx = lambda r: 1000 * r["cpu"] / r["frames"] / r["mpx"]
paras.append("CPU ms per camera-frame per Mpx at one thread, over the inputs where the stage ran. Within a factor "
             "of 2 on every input, a cost per pixel: " + ("; ".join(steady) or "none") + ". Varying more, a cost "
             "per feature or per motion more than per pixel: " + ("; ".join(varying) or "none") + ". The whole run "
             f"costs {whole_mpx(small):.0f} ms per Mpx on {small['name']} ({small['mpx']:.2f} Mpx per frame) and "
             f"{whole_mpx(big):.0f} on {big['name']} ({big['mpx']:.2f} Mpx)"
             + (": per Mpx, larger images cost less." if whole_mpx(big) < whole_mpx(small) else ".") )
su = [(r, r["share"]["start-up"] / 100.0 * r["cpu"]) for r in t1]
su_max = max(su, key=lambda x: x[1])[0]
su_part = su_max["startup"].most_common(1)[0] if su_max["startup"] else ("-", 0)
paras.append("Start-up (dynamic linking, the trackers and warp maps, the vocabulary, reading the dataset's index) "
             f"is {rng([s for _, s in su], '{:.2f}')} CPU s per run (most on {su_max['name']}, of which "
             f"{su_part[0]} {su_part[1] / su_max['period_total'] * su_max['cpu']:.2f} s), "
             f"{rng([r['share']['start-up'] for r, _ in su])} % of these runs; hashing the inputs and outputs "
             f"{rng([r['share']['hashing, input checks'] for r in t1])} %; outputs, evaluation and report "
             f"{rng([r['share']['outputs: eval, report, files'] for r in t1])} %; the global BA "
             f"{rng([r['share']['global BA'] for r in t1])} %.")
for name in names:
    r1, r2 = byname.get((name, 1)), byname.get((name, 2))
    if not (r1 and r2):
        continue
    diffs = sorted(STAGES, key=lambda s: -(per_frame(r2, s) - per_frame(r1, s)))
    d0 = diffs[0]
    paras.append(f"{name} at 2 threads: {r2['cpu'] / r2['frames']:.3f} CPU s/frame against "
                 f"{r1['cpu'] / r1['frames']:.3f} at 1 ({r2['cpu'] / r1['cpu']:.2f} x the CPU), wall "
                 f"{r2['wall']:.2f} against {r1['wall']:.2f} s ({r2['wall'] / r1['wall']:.2f} x). The stages that "
                 f"gain most CPU per frame: " + ", ".join(f"{d} {per_frame(r1, d):.4f} -> {per_frame(r2, d):.4f} s"
                                                        for d in diffs[:3]) + "; pool threads "
                 f"{100.0 * r1['pool_threads'] / r1['period_total']:.1f} -> "
                 f"{100.0 * r2['pool_threads'] / r2['period_total']:.1f} % of the CPU.")
pools = [100.0 * r["pool_threads"] / r["period_total"] for r in t1 if r["period_total"]]
if pools:
    paras.append(f"At --threads 1, {rng(pools)} % of the CPU ran on the libraries' pool threads (OpenCV's TBB "
                 f"workers, Ceres' pool): --threads does not hold those to one thread; "
                 f"{rng([r['share'][POOL_IDLE] for r in t1])} % was TBB's workers spinning or waiting for work.")
oth = max(runs, key=lambda r: r["share"]["other"])
over = [r for r in runs if r["cpu"] > 0]
paras.append(f"'other' (no stage frame on the stack) is at most {oth['share']['other']:.1f} % ({label(oth)}), "
             f"{'under' if oth['share']['other'] < 15 else '**over**'} the 15 % this profile aims for. Under perf "
             f"the runs took {rng([r['perf_cpu'] / r['cpu'] for r in over], '{:.2f}')} x their CPU without it; "
             f"stacks cut short: at most {max(100.0 * r['truncated'] / max(1, r['samples']) for r in runs):.1f} % "
             f"of a run's samples.")
loads = [float(load_before.split()[0]), float(load_after.split()[0])]  # the 1-minute load averages
if max(loads) > (os.cpu_count() or 1):
    paras.append(f"The machine was busy: load average {max(loads):.1f} on {os.cpu_count()} cores (the 1-minute "
                 "figure before or after). Other processes' work slows mcvo's threads down and inflates its CPU "
                 "seconds too (caches, memory bandwidth); wall seconds and the comparison of thread counts are "
                 "the least reliable figures here, the shares the most.")
for p in paras:
    print(p + "\n")

print("## Stage rules\n")
print("A frame is perf's demangled symbol and its file, `SYMBOL [FILE]`; `mcvo::` may follow a return type. "
      "Innermost matching frame wins; on one frame the first row. 'parent': the frame directly above "
      "(its caller) must match too; 'within': some frame above; 'claims all inside it': the frame anywhere on "
      "the stack takes the sample; `(ns::)*`: any namespaces, anonymous ones included.\n")
print(f"Placed by time, for samples no rule places: (1) a sample of a library's pool thread (no mcvo frame, a "
      f"frame of libtbb: OpenCV's parallel_for_ workers; of libceres: Ceres' pool) takes the stage of the "
      f"nearest sample, within {1000 * POOL_WINDOW_S:.0f} ms, of a thread inside that library's dispatcher "
      f"(`cv::parallel_for_`, `ceres::internal::ParallelFor`) called from the same library as the body the "
      f"worker runs (libopencv_video: LK; libopencv_imgproc: filters, CLAHE, resize ...); none: 'thread pool "
      f"work, caller not found'; a TBB worker in no OpenCV code: 'thread pools: spin, wait'. (2) a stack cut "
      f"short takes the stage of the same thread's nearest sample, within {1000 * CUT_WINDOW_S:.0f} ms, that "
      f"has a stage and the cut stack's outermost frame of a known file on its stack; failing that, the stage of "
      f"the same thread's nearest sample with a stage within {1000 * CUT_TIME_S:.0f} ms (stacks of one libc "
      f"frame: malloc, free, memset, where the unwinder stopped at once). Left over: 'other'.\n")
print("| stage | frame (Python regex) | condition |")
print("|---|---|---|")
for stage, rules in STAGE_RULES:
    for rx, cond in rules:
        c = ("-" if cond is None else "claims all inside it" if cond == CLAIMS
             else f"{cond[0]} `{cond[1].replace(M, 'mcvo::').replace(E, '$')}`")
        print(f"| {stage} | `{rx.replace(M, 'mcvo::').replace(E, '$').replace(NS, '(ns::)*').replace('|', '&#124;')}` | {c.replace('|', '&#124;')} |")
print()
print(f"CSV: `{out_csv}` (one row per input, thread count and stage; the numbers above to 6 significant digits).")
PY
cat "$OUT_MD"
