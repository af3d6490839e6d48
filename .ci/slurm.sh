#!/usr/bin/env bash
# A one-node Slurm cluster on this machine, for `hooke sweep --on slurm` and its tests: installs
# Debian's slurm-wlm and munge where they are missing, writes a config to a folder of its own,
# starts munged, slurmctld -D and slurmd -D in the background, and waits until `sinfo` shows the
# node idle. Run as root (CI is). Idempotent: a cluster already answering is left as it is.
#
#   bash .ci/slurm.sh          # start (or find) the cluster
#   bash .ci/slurm.sh stop     # stop what this script started
set -euo pipefail

dir="${HOOKE_SLURM_DIR:-/tmp/hooke-slurm}"
conf="$dir/slurm.conf"

if [ "${1:-start}" = stop ]; then
  for d in slurmd slurmctld munged; do
    pkill -x "$d" 2>/dev/null || true
  done
  echo "slurm: stopped"
  exit 0
fi

export DEBIAN_FRONTEND=noninteractive
if ! command -v sbatch >/dev/null || ! command -v slurmd >/dev/null || ! command -v munged >/dev/null; then
  apt-get update -qq
  apt-get install -y -qq slurm-wlm munge >/dev/null
fi

mkdir -p "$dir"
# Slurm's commands read /etc/slurm/slurm.conf unless SLURM_CONF says otherwise: point it at ours
# where the machine has none of its own, so that a plain `sbatch` (and `hooke sweep`) finds it.
if [ ! -e /etc/slurm/slurm.conf ] && [ ! -L /etc/slurm/slurm.conf ]; then
  mkdir -p /etc/slurm
  ln -s "$conf" /etc/slurm/slurm.conf
fi
if [ "$(readlink -f /etc/slurm/slurm.conf)" != "$(readlink -f "$conf" 2>/dev/null || echo "$conf")" ]; then
  export SLURM_CONF="$conf"
  echo "slurm: /etc/slurm/slurm.conf is another cluster's; this one is SLURM_CONF=$conf"
fi

if sinfo -h -o '%T' 2>/dev/null | grep -qx idle; then
  echo "slurm: already up ($(sinfo -h -o '%N %T %c cpus'))"
  exit 0
fi

host=$(hostname -s)
cpus=$(nproc)
mem_mb=$(awk '/MemTotal/ { print int($2 / 1024 * 0.8) }' /proc/meminfo)
mkdir -p "$dir/state" "$dir/spool" "$dir/log"
cat >"$conf" <<EOF
# Written by .ci/slurm.sh: one node, this machine, every core; no cgroups (containers lack them).
ClusterName=hooke
SlurmctldHost=$host
AuthType=auth/munge
CredType=cred/munge
SlurmUser=root
SlurmdUser=root
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
MpiDefault=none
InactiveLimit=0
KillWait=5
MinJobAge=300
NodeName=$host CPUs=$cpus RealMemory=$mem_mb State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF

# munge: the key Debian's package made, a socket folder, the daemon (it forks itself).
if ! pgrep -x munged >/dev/null; then
  mkdir -p /run/munge /var/log/munge /var/lib/munge
  if [ ! -s /etc/munge/munge.key ]; then
    mungekey --create --keyfile=/etc/munge/munge.key 2>/dev/null ||
      dd if=/dev/urandom bs=1 count=1024 of=/etc/munge/munge.key 2>/dev/null
  fi
  chown -R munge:munge /etc/munge /run/munge /var/log/munge /var/lib/munge 2>/dev/null || true
  chmod 0700 /etc/munge
  chmod 0400 /etc/munge/munge.key
  if id munge >/dev/null 2>&1; then
    runuser -u munge -- munged
  else
    munged --force
  fi
fi

pkill -x slurmd 2>/dev/null || true
pkill -x slurmctld 2>/dev/null || true
nohup slurmctld -D -f "$conf" >"$dir/log/slurmctld.out" 2>&1 &
nohup slurmd -D -f "$conf" >"$dir/log/slurmd.out" 2>&1 &

for _ in $(seq 1 60); do
  state=$(sinfo -h -o '%T' 2>/dev/null | head -1 || true)
  if [ "$state" = idle ]; then
    echo "slurm: up ($(sinfo -h -o '%N %T %c cpus'))"
    exit 0
  fi
  sleep 1
done
echo "slurm: the node did not come up idle within 60 s (sinfo: ${state:-no answer})." >&2
echo "slurm: logs in $dir/log:" >&2
tail -n 20 "$dir/log/slurmctld.out" "$dir/log/slurmd.out" "$dir/log/slurmctld.log" "$dir/log/slurmd.log" >&2 2>/dev/null || true
exit 1
