#!/usr/bin/env bash
# The Slurm recipe end to end (issue 24): a one-node Slurm (slurmctld, slurmd and munge
# from the distribution's packages, started here on loopback) runs
# deploy/slurm/heatrun-array.sbatch as a three-task array against a loopback S3 server
# (moto's, from PyPI): each task replays one recording of s3://fleet/in/ into
# s3://fleet/out/; then `heatrun fleet summary` must give three rows. Also checks the
# Kubernetes manifest against Kubernetes' schema (kubernetes-validate, from PyPI).
#
# Needs root (apt-get, munge's key, the daemons). Usage: tests/cluster/slurm.sh [HEATRUN]
# (default: $CARGO_TARGET_DIR/release/heatrun). Every daemon is stopped by its process id.
set -euo pipefail
cd "$(dirname "$0")/../.."
root="$PWD"
heatrun="$(realpath "${1:-${CARGO_TARGET_DIR:-target}/release/heatrun}")"
test -x "$heatrun" || { echo "slurm.sh: no heatrun binary at $heatrun" >&2; exit 1; }

# Prerequisites, installed only where missing.
command -v moto_server > /dev/null && command -v kubernetes-validate > /dev/null \
    || pip install --quiet "moto[server]" kubernetes-validate
if ! command -v sbatch > /dev/null || ! command -v munged > /dev/null; then
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurm-wlm munge > /dev/null
fi

# The Kubernetes manifest against the schema; a broken copy must fail (the check can fail).
kubernetes-validate --strict --quiet deploy/k8s/heatrun-indexed-job.yaml
work="$(mktemp -d)"
sed 's/completions: 3/completions: three/' deploy/k8s/heatrun-indexed-job.yaml > "$work/broken.yaml"
if kubernetes-validate --strict --quiet "$work/broken.yaml" > /dev/null 2>&1; then
    echo "slurm.sh: kubernetes-validate accepted a broken manifest" >&2; exit 1
fi
echo "deploy/k8s/heatrun-indexed-job.yaml: valid against Kubernetes' schema"

pids=()
cleanup() {
    for pid in "${pids[@]}"; do kill "$pid" 2> /dev/null || true; done
    for pid in "${pids[@]}"; do wait "$pid" 2> /dev/null || true; done
    # The daemons write their state as they stop (slurmctld saves its queue on SIGTERM), so
    # the directory is removed only once each has exited, or the removal races their writes.
    local daemons=()
    for f in "$work"/*.pid; do [ -s "$f" ] && daemons+=("$(cat "$f")"); done
    for pid in "${daemons[@]}"; do kill "$pid" 2> /dev/null || true; done
    for _ in $(seq 100); do
        local alive=0
        for pid in "${daemons[@]}"; do kill -0 "$pid" 2> /dev/null && alive=1; done
        [ "$alive" -eq 0 ] && break
        sleep 0.1
    done
    rm -rf "$work" 2> /dev/null || { sleep 1; rm -rf "$work"; }
}
trap cleanup EXIT

free_port() { python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])'; }

# The S3 server, its bucket and three recordings.
port="$(free_port)"
moto_server -H 127.0.0.1 -p "$port" > "$work/moto.log" 2>&1 &
pids+=($!)
export AWS_ENDPOINT_URL="http://127.0.0.1:$port" AWS_ALLOW_HTTP=true AWS_REGION=us-east-1
export AWS_ACCESS_KEY_ID=testing AWS_SECRET_ACCESS_KEY=testing
for _ in $(seq 300); do python3 -c "import socket; socket.create_connection(('127.0.0.1',$port),1)" 2> /dev/null && break; sleep 0.2; done
python3 - "$root/fixtures/paper_heat_run.mcap" << 'PY'
import sys, boto3
s3 = boto3.client("s3")
s3.create_bucket(Bucket="fleet")
for name in ("a", "b", "c"):
    s3.upload_file(sys.argv[1], "fleet", f"in/{name}.mcap")
PY

# munge, with a key of its own.
mkdir -p /etc/munge /run/munge /var/lib/munge /var/log/munge
[ -f /etc/munge/munge.key ] || mungekey -c -k /etc/munge/munge.key
chown -R munge: /etc/munge /run/munge /var/lib/munge
chmod 400 /etc/munge/munge.key
munged --force --pid-file="$work/munged.pid"
for _ in $(seq 50); do [ -s "$work/munged.pid" ] && break; sleep 0.1; done

# A one-node cluster on loopback (no systemd, no cgroups: no cgroup.conf at all).
host="$(hostname -s)"
mkdir -p "$work/state" "$work/spool" "$work/log"
cat > "$work/slurm.conf" << CONF
ClusterName=heatrun-test
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmdUser=root
SlurmctldPort=$(free_port)
SlurmdPort=$(free_port)
AuthType=auth/munge
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/log/slurmctld.log
SlurmdLogFile=$work/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
NodeName=$host NodeAddr=127.0.0.1 CPUs=2 State=UNKNOWN
PartitionName=debug Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
export SLURM_CONF="$work/slurm.conf"
slurmctld
slurmd
for _ in $(seq 150); do sinfo -h -o %t 2> /dev/null | grep -q idle && break; sleep 0.2; done
sinfo

# The array: three tasks, one recording each, outputs to the S3 prefix.
cd "$work"
sbatch --wait --array=0-2 --cpus-per-task=1 --mem=0 \
    --export=ALL,LISTING=s3://fleet/in/,OUT=s3://fleet/out/,HEATRUN="$heatrun" \
    "$root/deploy/slurm/heatrun-array.sbatch" \
    || { tail -n 20 "$work"/heatrun-*.out "$work/log/"*.log >&2; exit 1; }

"$heatrun" fleet summary s3://fleet/out/ --csv "$work/fleet-summary.csv"
rows="$(tail -n +2 "$work/fleet-summary.csv" | grep -c ',ok,')"
if [ "$rows" -ne 3 ]; then
    echo "slurm.sh: fleet summary has $rows ok rows, not 3" >&2
    cat "$work/fleet-summary.csv" >&2
    exit 1
fi
echo "Slurm array of 3 tasks against S3: fleet summary has 3 rows"
