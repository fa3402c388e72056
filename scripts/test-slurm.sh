#!/usr/bin/env bash
# Proves `joca experiment --slurm` for real: installs Slurm and munge from Debian if missing,
# starts a single-node cluster on localhost (every file under one scratch directory, traffic on
# loopback only), runs scripts/slurm-tiny.toml through it with --wait, runs the same grid locally,
# and checks that both give byte-identical results (same seeds, same thread count). Run by .ci/run;
# needs root (apt-get, daemons). Usage: scripts/test-slurm.sh
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$repo"

if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null; then
  echo "test-slurm: installing slurmctld slurmd slurm-client munge"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
    slurmctld slurmd slurm-client munge >/dev/null
fi

scripts/bootstrap-libtorch.sh >&2
cargo build --quiet --profile ci -p joca-cli
joca="$repo/target/ci/joca"

B="$(mktemp -d /tmp/joca-slurm.XXXXXX)"
mkdir -p "$B"/{munge,ctld,spool,run,log}
chmod 711 "$B" "$B/munge"
stop() {
  set +e
  [ -n "${SLURM_CONF:-}" ] && scancel --quiet --name=joca-slurm-tiny 2>/dev/null
  for p in "$B/run/slurmd.pid" "$B/run/slurmctld.pid" "$B/munge/munged.pid"; do
    [ -f "$p" ] && kill "$(cat "$p")" 2>/dev/null
  done
  sleep 1
}
trap stop EXIT

# munge: the authentication Slurm's daemons and clients share.
mungekey --create --keyfile="$B/munge/munge.key" 2>/dev/null || \
  dd if=/dev/urandom of="$B/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$B/munge/munge.key"
munged --force --key-file="$B/munge/munge.key" --socket="$B/munge/munge.sock" \
  --pid-file="$B/munge/munged.pid" --log-file="$B/munge/munged.log" --seed-file="$B/munge/munged.seed"

mem=$(( $(free -m | awk '/^Mem:/ {print $7}') * 9 / 10 ))
cpus=$(nproc)
cat > "$B/slurm.conf" <<CONF
ClusterName=joca
SlurmctldHost=localhost
SlurmUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$B/munge/munge.sock
SlurmctldPort=16817
SlurmdPort=16818
StateSaveLocation=$B/ctld
SlurmdSpoolDir=$B/spool
SlurmctldPidFile=$B/run/slurmctld.pid
SlurmdPidFile=$B/run/slurmd.pid
SlurmctldLogFile=$B/log/slurmctld.log
SlurmdLogFile=$B/log/slurmd.log
MailProg=/bin/true
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
SchedulerParameters=batch_sched_delay=0
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
MpiDefault=none
ReturnToService=2
SlurmdTimeout=30
InactiveLimit=0
KillWait=5
MinJobAge=300
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$cpus RealMemory=$mem State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$B/slurm.conf"
slurmctld -f "$SLURM_CONF"
slurmd -f "$SLURM_CONF" -N localhost
for _ in $(seq 1 60); do
  state="$(sinfo -h -N -n localhost -o %t 2>/dev/null || true)"
  [ "$state" = "idle" ] && break
  sleep 1
done
if [ "$state" != "idle" ]; then
  echo "test-slurm: the node did not come up (state '$state'); logs in $B/log" >&2
  tail -n 20 "$B/log/slurmctld.log" "$B/log/slurmd.log" >&2 || true
  exit 1
fi
echo "test-slurm: single-node Slurm is up in $B"

grid="$repo/scripts/slurm-tiny.toml"
start=$(date +%s)
"$joca" experiment "$grid" --out "$B/exp-slurm" --slurm --max-parallel 2 --wait
"$joca" experiment "$grid" --out "$B/exp-slurm" --status
"$joca" experiment "$grid" --out "$B/exp-local" --jobs 2 >/dev/null
echo "test-slurm: both grids done in $(( $(date +%s) - start )) s"

fail=0
for id in tacos-calibrated joca-calibrated tacos-blur4 joca-blur4; do
  if ! cmp -s "$B/exp-slurm/cells/$id/results.json" "$B/exp-local/cells/$id/results.json"; then
    echo "test-slurm: $id differs between Slurm and local" >&2; fail=1
  fi
done
cmp -s "$B/exp-slurm/results.csv" "$B/exp-local/results.csv" || { echo "test-slurm: results.csv differs" >&2; fail=1; }
# Every section but the wall time (measured, so it differs run to run) must match byte for byte;
# the wall-time section must be there in both.
timeless() {
  sed "s#$2#DIR#g" "$1" | awk '/^## Where the wall time went/ {skip = 1; next}
    skip && /^##? / {skip = 0} !skip'
}
if ! diff <(timeless "$B/exp-slurm/report.md" "$B/exp-slurm") \
  <(timeless "$B/exp-local/report.md" "$B/exp-local"); then
  echo "test-slurm: report.md differs" >&2; fail=1
fi
for side in slurm local; do
  grep -q '^## Where the wall time went' "$B/exp-$side/report.md" ||
    { echo "test-slurm: the $side report has no wall-time section" >&2; fail=1; }
done
ls "$B/exp-slurm/slurm/"*.log >/dev/null || { echo "test-slurm: no task logs" >&2; fail=1; }
if [ "$fail" -ne 0 ]; then exit 1; fi
echo "test-slurm: ok — the Slurm grid's report equals the local one"
rm -rf "$B/exp-slurm" "$B/exp-local"
