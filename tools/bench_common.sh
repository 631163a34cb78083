# Shared by the benchmark scripts (source it; not run on its own).

# seconds_of command... -> "wall cpu" seconds on stdout: the wall clock of the
# command, and the user + system seconds of it and all its threads. The
# command's output goes to $SCRATCH/last.log, printed on stderr if it fails.
# Only the CPU time counted after the interpreter started is the command's: a
# python3 that is a wrapper script (pyenv's shim) has children of its own.
# "wall user system" (the CPU seconds split) go to $SCRATCH/last.usage, for a
# caller that wants user and system apart (tools/bench_throughput.sh).
seconds_of() {
  python3 - "$SCRATCH/last.log" "$@" <<'PY' || { cat "$SCRATCH/last.log" >&2; return 1; }
import os, resource, subprocess, sys, time
log, cmd = sys.argv[1], sys.argv[2:]
before = resource.getrusage(resource.RUSAGE_CHILDREN)
start = time.monotonic()
with open(log, "w") as out:
    rc = subprocess.call(cmd, stdout=out, stderr=subprocess.STDOUT)
wall = time.monotonic() - start
usage = resource.getrusage(resource.RUSAGE_CHILDREN)
cpu = usage.ru_utime + usage.ru_stime - (before.ru_utime + before.ru_stime)
print(f"{wall:.3f} {cpu:.3f}")
with open(os.path.join(os.path.dirname(log), "last.usage"), "w") as f:
    f.write(f"{wall:.3f} {usage.ru_utime - before.ru_utime:.3f} {usage.ru_stime - before.ru_stime:.3f}\n")
sys.exit(rc)
PY
}
