# Shared by the benchmark scripts (source it; not run on its own).

# seconds_of command... -> "wall cpu" seconds on stdout: the wall clock of the
# command, and the user + system seconds of it and all its threads. The
# command's output goes to $SCRATCH/last.log, printed on stderr if it fails.
seconds_of() {
  python3 - "$SCRATCH/last.log" "$@" <<'PY' || { cat "$SCRATCH/last.log" >&2; return 1; }
import resource, subprocess, sys, time
log, cmd = sys.argv[1], sys.argv[2:]
start = time.monotonic()
with open(log, "w") as out:
    rc = subprocess.call(cmd, stdout=out, stderr=subprocess.STDOUT)
wall = time.monotonic() - start
usage = resource.getrusage(resource.RUSAGE_CHILDREN)
print(f"{wall:.3f} {usage.ru_utime + usage.ru_stime:.3f}")
sys.exit(rc)
PY
}
