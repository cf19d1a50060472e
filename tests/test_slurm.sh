#!/bin/sh
# SPDX-License-Identifier: Apache-2.0
# scripts/tools/slurm_batch.sh under a real Slurm: a private single-node
# cluster (Debian's slurm-wlm and munge, which scripts/setup.sh installs)
# started in a temporary folder with its own munge key, socket, ports and
# state, and stopped at the end; the machine's own Slurm, if any, is not
# touched (SLURM_CONF points at the private slurm.conf). Checks:
#  - a job array over a manifest of CGAL meshes writes, shard by shard, the
#    same files byte for byte as one `clvox batch` run, and every mesh is
#    reported once across the shards' JSON lines;
#  - an array cancelled (scancel) after its first outputs leaves only
#    complete outputs, and the same array submitted again resumes: the
#    outputs already there are skipped, the rest written, all equal to the
#    reference.
# The Makefile copies this script to build/$CONFIG/tests/test_slurm;
# tests/run_tests.sh runs it like the C test programs. It says SKIP (and
# why) where the Slurm daemons cannot start on the machine. Ends with one
# "N passed, N failed" line. docs/testing.md.
set -u
here=$(cd "$(dirname "$0")" && pwd)          # build/CONFIG/tests
build=$(dirname "$here")
repo=$(cd "$build/../.." && pwd)
bin=${CLVOX_BIN:-$build/clvox}
passed=0; failed=0
ok() { passed=$((passed + 1)); }
fail() { failed=$((failed + 1)); echo "FAIL: $*"; }
finish() { echo "$passed passed, $failed failed"; [ "$failed" -eq 0 ]; exit $?; }
skip() { echo "SKIP slurm tests: $*"; echo "0 passed, 0 failed"; exit 0; }

for c in munged slurmctld slurmd sbatch squeue scancel scontrol; do
  if ! command -v "$c" >/dev/null 2>&1; then
    echo "FAIL: $c not found (Debian packages slurm-wlm and munge; scripts/setup.sh installs them)"
    echo "0 passed, 1 failed"; exit 1
  fi
done
meshes="$repo/data/meshes"
names="cow bunny00 cube-ouvert cross elephant-with-holes camel anchor mech-holes-shark"
for m in $names; do
  if [ ! -f "$meshes/$m.off" ]; then
    if [ -n "${CLVOX_QUICK:-}" ]; then echo "quick run: real meshes absent, slurm cases skipped"; echo "0 passed, 0 failed"; exit 0; fi
    echo "FAIL: $meshes/$m.off missing (scripts/fetch_meshes.sh)"; echo "0 passed, 1 failed"; exit 1
  fi
done
tmp="${CLVOX_TEST_TMP:-$repo/build/test-tmp}/slurm"
rm -rf "$tmp"; mkdir -p "$tmp/state" "$tmp/spool" "$tmp/log" || exit 1
cd "$tmp" || exit 1

# ---- a private cluster ----
node=$(hostname -s)
port=$((20000 + $$ % 20000))
stop_cluster() {
  [ -f "$tmp/slurm.conf" ] && SLURM_CONF="$tmp/slurm.conf" scontrol shutdown >/dev/null 2>&1
  pids=""
  for p in slurmctld.pid slurmd.pid munged.pid; do
    [ -f "$tmp/$p" ] && pids="$pids $(cat "$tmp/$p")"
  done
  [ -n "$pids" ] && kill $pids 2>/dev/null
  for _ in $(seq 1 50); do # the daemons gone before the folder is reused
    kill -0 $pids 2>/dev/null || break
    sleep 0.2
  done
  return 0
}
trap stop_cluster EXIT
trap 'stop_cluster; exit 130' INT TERM
dd if=/dev/urandom of=munge.key bs=1024 count=1 2>/dev/null && chmod 600 munge.key
if ! munged --force --key-file="$tmp/munge.key" --socket="$tmp/munge.sock" --pid-file="$tmp/munged.pid" \
     --log-file="$tmp/log/munged.log" --seed-file="$tmp/munged.seed" 2>"$tmp/log/munged.err"; then
  skip "munged does not start here: $(head -c 300 "$tmp/log/munged.err")"
fi
cat > slurm.conf <<CONF
ClusterName=clvoxtest
SlurmctldHost=$node
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=$(id -un)
SlurmdUser=$(id -un)
AuthType=auth/munge
AuthInfo=socket=$tmp/munge.sock
CredType=cred/munge
StateSaveLocation=$tmp/state
SlurmdSpoolDir=$tmp/spool
SlurmctldPidFile=$tmp/slurmctld.pid
SlurmdPidFile=$tmp/slurmd.pid
SlurmctldLogFile=$tmp/log/slurmctld.log
SlurmdLogFile=$tmp/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerType=sched/builtin
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
MpiDefault=none
ReturnToService=2
PlugStackConfig=$tmp/plugstack.conf
NodeName=$node CPUs=$(nproc) State=UNKNOWN
PartitionName=clvox Nodes=$node Default=YES MaxTime=INFINITE State=UP
CONF
: > plugstack.conf
export SLURM_CONF="$tmp/slurm.conf"
slurmctld -f "$SLURM_CONF" 2>"$tmp/log/slurmctld.err" || skip "slurmctld does not start here: $(tail -n 3 "$tmp/log/slurmctld.log" 2>/dev/null)"
slurmd -f "$SLURM_CONF" 2>"$tmp/log/slurmd.err" || skip "slurmd does not start here: $(tail -n 3 "$tmp/log/slurmd.log" 2>/dev/null)"
up=""
for _ in $(seq 1 60); do
  if sinfo -h -o %t 2>/dev/null | grep -q idle; then up=1; break; fi
  sleep 0.5
done
[ -n "$up" ] || skip "the node did not come up: $(tail -n 3 "$tmp/log/slurmd.log" 2>/dev/null)"
echo "private Slurm up: $(sinfo -h -o '%P %D %t %C' 2>/dev/null) ($(slurmctld -V))"

# ---- the reference: one clvox batch run ----
for m in $names; do echo "$meshes/$m.off"; done > list.txt
total=$(wc -l < list.txt)
res=48
mkdir -p ref
"$bin" batch --manifest list.txt -r $res -o "$tmp/ref/{n}.exr" -q 2>ref.err
[ "$(ls ref/*.exr 2>/dev/null | wc -l)" -eq "$total" ] && ok || fail "reference batch: $(cat ref.err)"
script="$repo/scripts/tools/slurm_batch.sh"
export CLVOX="$bin"

same_as_ref() { # DIR WHAT: every output there equals the reference
  d=$1; n=0; bad=0
  for f in "$d"/*.exr; do
    [ -e "$f" ] || continue
    n=$((n + 1))
    cmp -s "$f" "ref/$(basename "$f")" || { bad=1; echo "  $f differs from ref/$(basename "$f")"; }
  done
  extra=$(ls -A "$d" | grep -v -E '^([0-9]+\.exr|shard-[0-9]+\.jsonl)$' || true)
  [ -z "$extra" ] || { bad=1; echo "  left behind in $d: $extra"; }
  [ "$bad" -eq 0 ] && ok || fail "$2: outputs differ from one clvox batch run"
  seen=$n
}
wait_job() { # JOBID: until the queue no longer holds it (sbatch --wait polls every 10 s or so)
  for _ in $(seq 1 1500); do
    [ -z "$(squeue -h -j "$1" 2>/dev/null)" ] && return 0
    sleep 0.2
  done
  return 1
}
records() { cat "$1"/shard-*.jsonl 2>/dev/null | grep '"type":"mesh"' | grep -c "\"status\":\"$2\""; }

# ---- 1. a job array of 3 tasks, all of it ----
jid=$(sbatch --parsable --cpus-per-task=1 --array=0-2 -o "$tmp/log/array-%a.log" "$script" list.txt out $res 2>sbatch1.txt)
if [ -n "$jid" ] && wait_job "$jid"; then ok
else fail "sbatch: $(cat sbatch1.txt; cat log/array-*.log 2>/dev/null | tail -n 5)"; fi
same_as_ref out "job array"
[ "$seen" -eq "$total" ] && ok || fail "job array wrote $seen of $total outputs"
[ "$(ls out/shard-*.jsonl 2>/dev/null | wc -l)" -eq 3 ] && ok || fail "expected 3 shard-K.jsonl files"
[ "$(records out ok)" -eq "$total" ] && ok || fail "JSON lines: $(records out ok) meshes ok, expected $total"

# ---- 2. cancelled after its first outputs, then resumed ----
jid=$(sbatch --parsable --cpus-per-task=1 --array=0-3%1 -o "$tmp/log/resume-%a.log" "$script" list.txt out2 $res 2>sbatch2.err)
if [ -z "$jid" ]; then fail "sbatch: $(cat sbatch2.err)"; finish; fi
got=""
for _ in $(seq 1 3000); do
  if [ "$(ls out2/*.exr 2>/dev/null | wc -l)" -ge 1 ]; then got=1; break; fi
  sleep 0.1
done
scancel "$jid"
wait_job "$jid" && ok || fail "job $jid still queued after scancel"
[ -n "$got" ] && ok || fail "no output within 300 s of submitting (a hang guard, not a timing check)"
same_as_ref out2 "cancelled array"
before=$seen
[ "$before" -ge 1 ] && [ "$before" -lt "$total" ] && ok || echo "note: $before of $total outputs before the cancel"
jid=$(sbatch --parsable --cpus-per-task=1 --array=0-3%1 -o "$tmp/log/resume2-%a.log" "$script" list.txt out2 $res 2>sbatch3.txt)
if [ -n "$jid" ] && wait_job "$jid"; then ok
else fail "resubmitted array: $(cat sbatch3.txt)"; fi
same_as_ref out2 "resumed array"
[ "$seen" -eq "$total" ] && ok || fail "resumed array: $seen of $total outputs"
sk=$(records out2 skipped); okc=$(records out2 ok)
[ "$sk" -eq "$before" ] && [ $((sk + okc)) -eq "$total" ] && ok ||
  fail "resumed array: $sk skipped and $okc ok, expected $before skipped of $total"
echo "resume: $before of $total outputs before scancel, $sk skipped after"

# ---- 3. the script refuses to run outside an array ----
if env -u SLURM_ARRAY_TASK_ID -u SLURM_ARRAY_TASK_COUNT sh "$script" list.txt out3 2>err3.txt; then
  fail "slurm_batch.sh outside an array should fail"
else grep -q "not a job array task" err3.txt && ok || fail "message: $(cat err3.txt)"; fi
finish
