#!/usr/bin/env bash
# The Slurm recipe (deploy/slurm/farm.sh) on a real single-node cluster on this machine:
# munged, slurmctld and slurmd started directly (no systemd), everything under a
# temporary directory, every daemon stopped by its pid at the end, also on failure.
#
#   tests/slurm/run.sh RAYTRACER      (as root: it installs Debian's slurm packages if
#                                      they are missing)
#
# 1. `bunny` in 4 parts and the merge job; the merged EXR is `cmp`-equal to a
#    one-process render.
# 2. Faults: part 2's render is killed (SIGKILL, mid-render); its task fails, the merge
#    job never runs, no part-2.part exists, and a merge of the parts there reports
#    exactly "missing region 2/4". Resubmitting task 2 and the merge completes the frame
#    with the same bits.
set -euo pipefail

die() { echo "slurm test: FAILED: $*" >&2; exit 1; }
log() { echo "slurm test: $*" >&2; }
started=$(date +%s%N)
# Seconds since a `date +%s%N` time, to a tenth.
since() { local ms=$((($(date +%s%N) - $1) / 1000000)); printf '%d.%d' $((ms / 1000)) $((ms % 1000 / 100)); }

[ $# -eq 1 ] || die "usage: $0 RAYTRACER"
bin=$(realpath -- "$1")
[ -x "$bin" ] || die "$1 is not an executable"
repo=$(cd "$(dirname "$0")/../.." && pwd)
farm=$repo/deploy/slurm/farm.sh
[ "$(id -u)" = 0 ] || die "needs root (packages, daemons)"

# Packages.
if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null ||
  ! command -v munged >/dev/null || ! command -v sbatch >/dev/null; then
  log "installing slurmctld, slurmd, slurm-client and munge"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
    slurmctld slurmd slurm-client munge >/dev/null
fi

tmp=$(mktemp -d /tmp/raytracer-slurm.XXXXXX)
chmod 755 "$tmp"

# Stop daemons by the pids in their pid files: TERM, then KILL those alive after 10 s.
stop() {
  local pidfile pids=() pid n alive
  for pidfile in "$@"; do
    [ -s "$pidfile" ] && pid=$(cat "$pidfile") && kill -TERM "$pid" 2>/dev/null && pids+=("$pid")
  done
  for ((n = 0; n < 100; n++)); do
    alive=()
    for pid in "${pids[@]}"; do kill -0 "$pid" 2>/dev/null && alive+=("$pid"); done
    [ ${#alive[@]} -gt 0 ] || return 0
    sleep 0.1
  done
  log "daemons ${alive[*]} ignored TERM for 10 s: KILL"
  kill -KILL "${alive[@]}" 2>/dev/null || true
}
stop_daemons() {
  # Slurm's first (they may still talk to munged as they stop).
  stop "$tmp/slurmd.pid" "$tmp/slurmctld.pid"
  stop "$tmp/munge/munged.pid"
  # slurmctld's helper slurmscriptd exits a moment after slurmctld.
  local n
  for ((n = 0; n < 50; n++)); do
    pgrep -f -- "$tmp/slurm.conf" >/dev/null 2>&1 || break
    sleep 0.1
  done
}
cleanup() {
  local status=$?
  local stopping
  stopping=$(date +%s%N)
  stop_daemons
  log "daemons stopped ($(since "$stopping") s)"
  if [ $status -ne 0 ]; then
    for f in "$tmp"/slurmctld.log "$tmp"/slurmd.log "$tmp"/munge/munged.log "$tmp"/run*/logs/*.log; do
      [ -f "$f" ] || continue
      echo "---- $f (last lines)" >&2
      tail -n 15 "$f" >&2
    done
  fi
  rm -rf "$tmp"
  exit $status
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# munge: its own key, socket, pid, log and seed under $tmp.
mkdir -m 755 "$tmp/munge"
head -c 1024 /dev/urandom >"$tmp/munge/munge.key"
chmod 400 "$tmp/munge/munge.key"
munged --key-file="$tmp/munge/munge.key" --socket="$tmp/munge/munge.socket.2" \
  --pid-file="$tmp/munge/munged.pid" --log-file="$tmp/munge/munged.log" \
  --seed-file="$tmp/munge/munged.seed" --force --origin=127.0.0.1

# slurm.conf: one node, this host, at 127.0.0.1; no cgroups, no accounting. The two
# daemons listen on ports no one else uses (not Slurm's 6817 and 6818), so another
# cluster on the machine, or another run of this test, is no matter.
host=$(hostname -s)
used=$(ss -Htan 2>/dev/null | awk '{ sub(/.*:/, "", $4); print $4 }' || true)
free_port() {
  local port
  for ((port = $1; port < $1 + 1000; port++)); do
    grep -qx "$port" <<<"$used" || { echo "$port"; return; }
  done
  die "no free port from $1"
}
ctld_port=$(free_port $((20000 + RANDOM % 20000)))
used+=$'\n'$ctld_port
slurmd_port=$(free_port $((ctld_port + 1)))
node=$(slurmd -C | head -n 1 | sed 's/^NodeName=[^ ]* //')
cat >"$tmp/slurm.conf" <<CONF
ClusterName=raytracer-test
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$tmp/munge/munge.socket.2
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerParameters=batch_sched_delay=0
MinJobAge=300
ReturnToService=2
KillWait=5
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd.pid
SlurmctldLogFile=$tmp/slurmctld.log
SlurmdLogFile=$tmp/slurmd.log
NodeName=$host NodeAddr=127.0.0.1 $node State=UNKNOWN
PartitionName=main Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
mkdir -p "$tmp/state" "$tmp/spool"
export SLURM_CONF=$tmp/slurm.conf
daemons_started=$(date +%s)
slurmctld -i -f "$SLURM_CONF"
slurmd -f "$SLURM_CONF"

# Ready: the node idle, and slurmd registered after we started it.
for ((n = 0; ; n++)); do
  state=$(sinfo -h -o %T 2>/dev/null || true)
  if [ "$state" = idle ]; then
    boot=$(scontrol show node "$host" | sed -n 's/.*SlurmdStartTime=\([^ ]*\).*/\1/p')
    [ -n "$boot" ] && [ "$(date -d "$boot" +%s 2>/dev/null || echo 0)" -ge "$daemons_started" ] && break
  fi
  [ $n -lt 300 ] || die "the node did not become idle in 30 s (sinfo: '$state')"
  sleep 0.1
done
log "cluster up on $host: $(scontrol show node "$host" | grep -o 'CPUTot=[0-9]*')"

# The states of a job's records (an array's tasks one a line).
states() { scontrol show job -o "$1" 2>/dev/null | grep -o 'JobState=[A-Z_]*' | cut -d= -f2; }
# Wait until no record of job $1 is pending, configuring or running (at most $2 s).
wait_job() {
  local n s
  for ((n = 0; n < $2 * 5; n++)); do
    s=$(states "$1")
    [ -n "$s" ] || die "no job $1"
    if ! grep -qE '^(PENDING|CONFIGURING|RUNNING|COMPLETING)$' <<<"$s"; then
      return 0
    fi
    sleep 0.2
  done
  die "job $1 still not finished after $2 s: $(echo $s)"
}
submit() { "$farm" --raytracer "$1" "${@:2}"; }
job_of() { sed -n "s/.*$1=\([0-9a-z]*\).*/\1/p" <<<"$2"; }

# The one-process reference.
scene=(bunny)
"$bin" "${scene[@]}" -q -o "$tmp/one.exr"

# 1. Four parts and the merge.
t0=$(date +%s%N)
ids=$(submit "$bin" "${scene[@]}" 4 "$tmp/run1" "$tmp/run1/bunny.exr")
parts=$(job_of parts "$ids") merge=$(job_of merge "$ids")
wait_job "$merge" 300
[ "$(states "$merge")" = COMPLETED ] || die "merge job $merge: $(states "$merge")"
[ "$(states "$parts" | sort -u)" = COMPLETED ] || die "part jobs: $(states "$parts" | tr '\n' ' ')"
cmp "$tmp/one.exr" "$tmp/run1/bunny.exr" || die "merged frame differs from the one-process render"
log "4 parts + merge: the same bits as one process ($(since "$t0") s from submit)"

# 2. Part 2 killed mid-render.
cat >"$tmp/killer" <<KILLER
#!/usr/bin/env bash
# The raytracer, but part 2 is killed (SIGKILL) once its render has started (its worker
# threads are up), as a crashed node or an OOM kill would end it.
if [ "\${SLURM_ARRAY_TASK_ID:-}" != 2 ]; then exec "$bin" "\$@"; fi
"$bin" "\$@" &
pid=\$!
for ((n = 0; n < 10000; n++)); do
  threads=\$(sed -n 's/^Threads:[[:space:]]*//p' /proc/\$pid/status 2>/dev/null || echo 0)
  [ "\${threads:-0}" -lt 2 ] || break
  sleep 0.001
done
kill -KILL \$pid || { echo "part 2 ended before it could be killed" >&2; exit 3; }
wait \$pid
KILLER
chmod +x "$tmp/killer"
ids=$(submit "$tmp/killer" "${scene[@]}" 4 "$tmp/run2" "$tmp/run2/bunny.exr")
parts=$(job_of parts "$ids") merge=$(job_of merge "$ids")
wait_job "$parts" 300
wait_job "$merge" 60
task_states=$(scontrol show job -o "$parts" | sed -n 's/.*ArrayTaskId=\([0-9]*\) .*JobState=\([A-Z_]*\).*/\1 \2/p' | sort)
log "tasks: $(echo $task_states); merge job: $(states "$merge")"
[ "$(grep -c ' COMPLETED$' <<<"$task_states")" = 3 ] || die "3 tasks should complete: $task_states"
grep -qE '^2 (FAILED|CANCELLED)' <<<"$task_states" || die "task 2 should fail: $task_states"
exit_code=$(scontrol show job -o "${parts}_2" | grep -o ' ExitCode=[0-9:]*' | cut -d= -f2)
[ "$exit_code" = 137:0 ] || die "task 2 should end by SIGKILL (exit 137): ExitCode=$exit_code"
[ "$(states "$merge")" = CANCELLED ] || die "merge job should be cancelled: $(states "$merge")"
[ ! -e "$tmp/run2/bunny.exr" ] || die "the merge wrote a frame without part 2"
[ ! -e "$tmp/run2/part-2.part" ] || die "the killed task left a part"
leftovers=$(find "$tmp/run2" -maxdepth 1 -name '.raytracer-*' | wc -l)
[ "$leftovers" = 0 ] || log "note: $leftovers temporary files of the killed task (SIGKILL cannot be caught)"
set +e
message=$("$bin" merge "$tmp"/run2/part-*.part -o "$tmp/run2/bunny.exr" 2>&1)
status=$?
set -e
[ $status = 2 ] || die "merge without part 2: exit $status, expected 2: $message"
grep -q 'missing region 2/4' <<<"$message" || die "merge without part 2: $message"
[ ! -e "$tmp/run2/bunny.exr" ] || die "a failed merge wrote a frame"
log "part 2 killed: merge job cancelled, no part-2.part, merge says: $message"

# Resubmit part 2 and the merge.
ids=$(submit "$bin" --tasks 2 "${scene[@]}" 4 "$tmp/run2" "$tmp/run2/bunny.exr")
merge=$(job_of merge "$ids")
wait_job "$merge" 300
[ "$(states "$merge")" = COMPLETED ] || die "merge after resubmitting part 2: $(states "$merge")"
cmp "$tmp/one.exr" "$tmp/run2/bunny.exr" || die "the repaired frame differs from the one-process render"
log "part 2 resubmitted: the same bits as one process"

log "$(since "$started") s from the start, before the daemons stop"
echo "slurm: 2 passed, 0 failed"
