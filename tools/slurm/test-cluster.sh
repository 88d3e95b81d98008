#!/usr/bin/env bash
# Tests demcal's Slurm executor against a real Slurm: a one-node cluster (slurmctld and slurmd
# from Debian, both as root on 127.0.0.1, configuration in a temporary folder) runs
#   1. a study of the `function` test, whose coordinator is killed (kill -9) while its first
#      array runs and then started again: it must re-attach, submit no run twice, and end with
#      exactly the results of the same study run by the local executor;
#   2. a tiny angle-of-repose study, compared with the local executor in the same way;
#   3. a study with runs longer than Slurm's time limit (1 minute): those must be stored as
#      failed with Slurm's reason while the stage's other runs finish.
# It stops the daemons it started (by pid) whatever happens. Needs root, apt (when Slurm is not
# installed), python3 and cargo (unless DEMCAL names a demcal binary). Last line:
#   slurm: runs=N jobs=M resumed=yes equal_to_local=yes wall_s=T
# KEEP=1 keeps the temporary folder for a look afterwards.
set -euo pipefail
repo="$(cd "$(dirname "$0")/../.." && pwd)"
check() { python3 "$repo/tools/slurm/store_check.py" "$@"; }
t0=$(date +%s)
say() { echo "slurm-test: $*" >&2; }
die() { say "FAILED: $*"; exit 1; }

if [ -z "${DEMCAL:-}" ]; then
  # The test profile's binary: already built (and optimised) by `cargo test`.
  (cd "$repo" && cargo build --profile test -p demcal-cli --quiet)
  DEMCAL="${CARGO_TARGET_DIR:-$repo/target}/debug/demcal"
fi
[ -x "$DEMCAL" ] || die "no demcal binary at $DEMCAL"
if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null || ! command -v sbatch >/dev/null; then
  say "installing slurmctld and slurmd"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurmctld slurmd slurm-client >/dev/null
fi
command -v python3 >/dev/null || die "python3 is needed to read the results stores"

work="$(mktemp -d /tmp/demcal-slurm.XXXXXX)"
pids=()        # coordinators started in the background
ctld_pid=""    # the daemons, started in the foreground mode (-D) so that $! is theirs
slurmd_pid=""
stop() { # pid: TERM, then KILL after 5 s
  [ -n "$1" ] || return 0
  kill "$1" 2>/dev/null || return 0
  for _ in $(seq 50); do kill -0 "$1" 2>/dev/null || return 0; sleep 0.1; done
  kill -9 "$1" 2>/dev/null
}
cleanup() {
  local rc=$?
  set +e
  for p in "${pids[@]}"; do kill -9 "$p" 2>/dev/null; done
  if [ -n "$ctld_pid" ]; then
    scancel --quiet --full "--user=$(id -un)" 2>/dev/null
    for _ in $(seq 10); do [ -z "$(squeue --noheader 2>/dev/null)" ] && break; sleep 0.5; done
  fi
  # The tasks' processes outlive slurmd: ended by their pids first.
  if [ -n "$slurmd_pid" ]; then
    scontrol listpids 2>/dev/null | awk 'NR > 1 && $1 ~ /^[0-9]+$/ { print $1 }' | xargs -r kill -9 2>/dev/null
  fi
  stop "$slurmd_pid"
  stop "$ctld_pid"
  if [ "$rc" != 0 ]; then
    say "logs of the failed run:"
    tail -n 20 "$work"/slurm/log/*.log "$work"/*.log 2>/dev/null >&2
  fi
  if [ -n "${KEEP:-}" ]; then say "kept $work"; else rm -rf "$work"; fi
  exit "$rc"
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
# A coordinator in the background, waited for at most $2 seconds.
wait_for() {
  for _ in $(seq $(($2 * 10))); do kill -0 "$1" 2>/dev/null || break; sleep 0.1; done
  if kill -0 "$1" 2>/dev/null; then kill -9 "$1"; die "a coordinator ran longer than $2 s"; fi
  wait "$1"
}

# ---- a one-node cluster -------------------------------------------------------------------
host="$(hostname -s)"
read -r ctld_port slurmd_port < <(python3 -c '
import socket
s = [socket.socket() for _ in range(2)]
for x in s: x.bind(("127.0.0.1", 0))
print(*[x.getsockname()[1] for x in s])')
mkdir -p "$work/slurm/state" "$work/slurm/spool" "$work/slurm/log"
# Four CPUs on a two-core machine (config_overrides): the time-limit study's runs only sleep.
cat >"$work/slurm/slurm.conf" <<EOF
ClusterName=demcaltest
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/none
CredType=cred/none
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SlurmdParameters=config_overrides
ReturnToService=2
SchedulerParameters=bf_interval=1,sched_interval=1,sched_min_interval=0
KillWait=2
MinJobAge=600
StateSaveLocation=$work/slurm/state
SlurmdSpoolDir=$work/slurm/spool
SlurmctldPidFile=$work/slurm/slurmctld.pid
SlurmdPidFile=$work/slurm/slurmd.pid
SlurmctldLogFile=$work/slurm/log/slurmctld.log
SlurmdLogFile=$work/slurm/log/slurmd.log
NodeName=$host NodeAddr=127.0.0.1 CPUs=4 State=UNKNOWN
PartitionName=test Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF="$work/slurm/slurm.conf"
slurmctld -D -i >"$work/slurm/log/slurmctld.out" 2>&1 &
ctld_pid=$!
slurmd -D -N "$host" >"$work/slurm/log/slurmd.out" 2>&1 &
slurmd_pid=$!
for i in $(seq 60); do
  sinfo --noheader --format=%t 2>/dev/null | grep -Eq '^(idle|mix|alloc)' && break
  [ "$i" = 60 ] && die "the node did not come up (see $work/slurm/log)"
  sleep 0.5
done
say "cluster up: node $host, slurmctld on port $ctld_port"

# ---- the studies --------------------------------------------------------------------------
executor() { # poll_s, max_running, extra lines
  printf '\n[executor]\nkind = "slurm"\npoll_s = %s\nmax_running = %s\n%s\n' "$1" "$2" "${3:-}"
}
mkdir -p "$work/bowl" "$work/bowl-local" "$work/heap" "$work/heap-local" "$work/limit"
bowl='name = "bowl"
seed = 3
plan = ["screening", "steepest", "rsm", "optimize", "validate"]

[test]
test = "function"
[test.function]
expression = "30 + 10*((a - 0.6)^2 + (b - 0.3)^2) + 0.01*c + 0.01*d"
variables = { a = 0.8, b = 0.5, c = 0.5, d = 0.5 }
noise = 0.02
fail_when = "c + d - 1.7"
duration_s = 1.0
'
for p in "a 0.4 1.2" "b 0.1 0.9" "c 0.0 1.0" "d 0.0 1.0"; do
  set -- $p
  bowl+="
[[parameter]]
name = \"$1\"
path = \"function.variables.$1\"
min = $2
max = $3
"
done
bowl+='
[target]
value = 30.0
'
printf '%s' "$bowl" >"$work/bowl-local/study.toml"
{ printf '%s' "$bowl"; executor 1 2; } >"$work/bowl/study.toml"

sed 's/count = 500/count = 200/' "$repo/examples/quickstart/repose.toml" >"$work/heap/repose.toml"
cp "$work/heap/repose.toml" "$work/heap-local/repose.toml"
heap='name = "tiny heap"
seed = 1
test = "repose.toml"
plan = [{ stage = "screening", design = "factorial" }]

[[parameter]]
name = "static_friction"
path = "interaction[bead,bead].static_friction"
min = 0.3
max = 0.7

[[parameter]]
name = "rolling_friction"
path = "interaction[bead,bead].rolling_friction"
min = 0.05
max = 0.15

[target]
response = "angle_of_repose_deg"
value = 18.5
unit = "deg"
'
printf '%s' "$heap" >"$work/heap-local/study.toml"
{ printf '%s' "$heap"; executor 1 2; } >"$work/heap/study.toml"

# Runs of 0.5 s and of 150 s (log scale: the centre point takes 8.7 s) under a 1 minute limit.
cat >"$work/limit/study.toml" <<EOF
name = "time limit"
seed = 5
plan = [{ stage = "screening", design = "factorial" }]

[test]
test = "function"
[test.function]
expression = "20 + a"
variables = { a = 1.0 }
duration_s = 1.0

[[parameter]]
name = "a"
path = "function.variables.a"
min = 0.0
max = 2.0

[[parameter]]
name = "duration"
path = "function.duration_s"
min = 0.5
max = 150.0
scale = "log"

[target]
value = 21.0
$(executor 1 4 'time_limit = "1"')
EOF

# ---- 3 starts first: it spends a minute waiting for Slurm's time limit --------------------
"$DEMCAL" run "$work/limit/study.toml" >"$work/limit.log" 2>&1 &
limit_pid=$!
pids+=("$limit_pid")

# ---- 1: kill the coordinator while its array runs, start it again -------------------------
"$DEMCAL" run "$work/bowl/study.toml" >"$work/bowl-1.log" 2>&1 &
bowl_pid=$!
pids+=("$bowl_pid")
db="$work/bowl/study.db"
for i in $(seq 600); do
  n=$([ -f "$db" ] && check count "$db" 2>/dev/null || echo 0)
  [ "$n" -ge 3 ] && break
  kill -0 "$bowl_pid" 2>/dev/null || die "the coordinator ended before it was to be killed: $(tail -n 5 "$work/bowl-1.log")"
  [ "$i" = 600 ] && die "no run finished in 60 s: $(tail -n 5 "$work/bowl-1.log")"
  sleep 0.1
done
kill -9 "$bowl_pid"
wait "$bowl_pid" 2>/dev/null || true
stored_at_kill=$(check count "$db")
open_jobs=$(check jobs "$db" open)
[ -n "$open_jobs" ] || die "no task was open when the coordinator was killed"
queued_at_kill=$(squeue --noheader --array "--jobs=$open_jobs" | wc -l)
[ "$queued_at_kill" -gt 0 ] || die "none of the array's tasks was queued or running when the coordinator was killed"
say "killed the coordinator with $stored_at_kill runs stored and $queued_at_kill of its tasks queued or running"
status="$("$DEMCAL" status "$work/bowl/study.toml")"
echo "$status" | grep -Eq '^  1\. screening +job [0-9]+: [0-9]+ queued( \([^)]*\))?, [0-9]+ running, [0-9]+ finished' ||
  die "demcal status does not show the array's tasks: $status"
# As if it had been killed between writing its tasks and recording sbatch's answer: the resumed
# coordinator must find the array by its job name.
forgot=$(check forget-job-ids "$db")
timeout 300 "$DEMCAL" run "$work/bowl/study.toml" >"$work/bowl-2.log" 2>&1 ||
  die "the resumed study failed: $(tail -n 5 "$work/bowl-2.log")"
grep -q "re-attached to" "$work/bowl-2.log" || die "the resumed coordinator did not re-attach: $(head -n 5 "$work/bowl-2.log")"
grep -q "state: complete" "$work/bowl-2.log" || die "the resumed study did not complete"
read -r bowl_runs bowl_jobs bowl_tasks < <(check ledger "$db")
say "bowl: $bowl_runs runs from $bowl_tasks tasks in $bowl_jobs arrays (none submitted twice; $forgot job ids found again by name)"
timeout 300 "$DEMCAL" run "$work/bowl-local/study.toml" --jobs 2 >"$work/bowl-local.log" 2>&1 ||
  die "the local run failed: $(tail -n 5 "$work/bowl-local.log")"
check equal "$db" "$work/bowl-local/study.db" >/dev/null || die "the Slurm and local bowl results differ"

# ---- Ctrl-C with on_interrupt = "cancel": the stage's tasks are withdrawn -------------------
mkdir -p "$work/cancel"
{ printf '%s' "$bowl"; executor 1 1 'on_interrupt = "cancel"'; } >"$work/cancel/study.toml"
"$DEMCAL" run "$work/cancel/study.toml" >"$work/cancel.log" 2>&1 &
cancel_pid=$!
pids+=("$cancel_pid")
for i in $(seq 600); do
  [ -f "$work/cancel/study.db" ] && [ "$(check count "$work/cancel/study.db" 2>/dev/null || echo 0)" -ge 1 ] && break
  [ "$i" = 600 ] && die "no run finished in 60 s: $(tail -n 5 "$work/cancel.log")"
  sleep 0.1
done
kill -INT "$cancel_pid"
wait_for "$cancel_pid" 60 && die "an interrupted study exited 0"
grep -Eq "cancelled [0-9]+ queued or running task" "$work/cancel.log" || die "Ctrl-C did not cancel: $(tail -n 3 "$work/cancel.log")"
cancel_jobs=$(check jobs "$work/cancel/study.db" cancelled)
[ "$(check tasks "$work/cancel/study.db" open)" = 0 ] && [ -n "$cancel_jobs" ] || die "the cancelled tasks are not closed in the store"
for i in $(seq 30); do # a cancelled task may be completing for a moment
  [ "$(squeue --noheader --array "--jobs=$cancel_jobs" | wc -l)" = 0 ] && break
  [ "$i" = 30 ] && die "cancelled tasks are still queued"
  sleep 0.5
done
say "Ctrl-C cancelled $(check tasks "$work/cancel/study.db" cancelled) queued or running tasks"
# --restart withdraws the old results' tasks still out before it moves the store aside.
"$DEMCAL" run "$work/cancel/study.toml" >"$work/cancel-2.log" 2>&1 &
cancel_pid=$!
pids+=("$cancel_pid")
for i in $(seq 300); do
  old_jobs=$(check jobs "$work/cancel/study.db" open 2>/dev/null) && [ -n "$old_jobs" ] && break
  [ "$i" = 300 ] && die "the resumed study submitted nothing: $(tail -n 3 "$work/cancel-2.log")"
  sleep 0.1
done
kill -9 "$cancel_pid"
wait "$cancel_pid" 2>/dev/null || true
timeout 120 "$DEMCAL" run "$work/cancel/study.toml" --restart >"$work/cancel-3.log" 2>&1 &
cancel_pid=$!
pids+=("$cancel_pid")
for i in $(seq 300); do
  grep -q "submitted job" "$work/cancel-3.log" && break
  [ "$i" = 300 ] && die "the restarted study submitted nothing: $(tail -n 3 "$work/cancel-3.log")"
  sleep 0.1
done
kill -INT "$cancel_pid"
wait_for "$cancel_pid" 60 || true
grep -Eq "^cancelled [0-9]+ Slurm task\(s\) of the old results" "$work/cancel-3.log" ||
  die "--restart did not cancel the old tasks: $(head -n 3 "$work/cancel-3.log")"
for i in $(seq 30); do
  [ "$(squeue --noheader --array "--jobs=$old_jobs" | wc -l)" = 0 ] && break
  [ "$i" = 30 ] && die "the old results' tasks are still queued after --restart"
  sleep 0.5
done

# ---- 2: a tiny repose study ---------------------------------------------------------------
timeout 300 "$DEMCAL" run "$work/heap/study.toml" >"$work/heap.log" 2>&1 ||
  grep -q "^state: " "$work/heap.log" || die "the repose study failed: $(tail -n 5 "$work/heap.log")"
read -r heap_runs heap_jobs _ < <(check ledger "$work/heap/study.db")
timeout 300 "$DEMCAL" run "$work/heap-local/study.toml" >"$work/heap-local.log" 2>&1 ||
  grep -q "^state: " "$work/heap-local.log" || die "the local repose study failed"
check equal "$work/heap/study.db" "$work/heap-local/study.db" >/dev/null ||
  die "the Slurm and local repose results differ"
say "repose: $heap_runs runs in $heap_jobs array(s), equal to the local executor's"

# ---- 3: the time limit --------------------------------------------------------------------
wait_for "$limit_pid" 300 || true
long=$(check timelimit "$work/limit/study.db" duration 100) ||
  die "time-limit study: $(tail -n 8 "$work/limit.log")"
limit_runs=$(check count "$work/limit/study.db")
say "time limit: $long of $limit_runs runs stopped by Slurm and stored as failed; the others done"
grep -q "Slurm stopped the task at its time limit" "$work/limit.log" || die "the time-limit failures were not reported"

# ---- 4: a node failure: the runs it killed are submitted again ------------------------------
mkdir -p "$work/node"
sed -e 's/^name = "time limit"/name = "node failure"/' -e 's/^min = 0.5$/min = 4.0/' -e 's/^max = 150.0$/max = 6.0/' \
  -e 's/^time_limit = "1"$/sbatch_lines = ["--no-requeue"]/' "$work/limit/study.toml" >"$work/node/study.toml"
"$DEMCAL" run "$work/node/study.toml" >"$work/node.log" 2>&1 &
node_pid=$!
pids+=("$node_pid")
for i in $(seq 300); do
  [ -f "$work/node/study.db" ] && jid=$(check jobs "$work/node/study.db" open 2>/dev/null) && [ -n "$jid" ] &&
    squeue --noheader --array "--jobs=$jid" --states=RUNNING | grep -q . && break
  [ "$i" = 300 ] && die "the node-failure study's tasks never ran: $(tail -n 5 "$work/node.log")"
  sleep 0.1
done
scontrol update "NodeName=$host" State=DOWN Reason=demcal-test
sleep 1
# With ReturnToService=2 the node may come back by itself (then RESUME is refused).
scontrol update "NodeName=$host" State=RESUME 2>/dev/null || true
for i in $(seq 60); do
  sinfo --noheader --format=%t | grep -Eq '^(idle|mix|alloc)' && break
  [ "$i" = 60 ] && die "the node did not come back after the simulated failure"
  sleep 0.5
done
wait_for "$node_pid" 300 || true
grep -q "will be submitted again: its node failed" "$work/node.log" ||
  die "no run was submitted again after the node failed: $(tail -n 5 "$work/node.log")"
node_runs=$(check done "$work/node/study.db") || die "node-failure study: $(tail -n 5 "$work/node.log")"
retried=$(check tasks "$work/node/study.db" retried)
say "node failure: $retried task(s) submitted again, all $node_runs runs done"

runs=$((bowl_runs + heap_runs + limit_runs + node_runs))
jobs=$((bowl_jobs + heap_jobs + $(check arrays "$work/limit/study.db") + $(check arrays "$work/node/study.db")))
echo "slurm: runs=$runs jobs=$jobs resumed=yes equal_to_local=yes wall_s=$(($(date +%s) - t0))"
