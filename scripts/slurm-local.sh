#!/usr/bin/env bash
# A one-node Slurm cluster on this machine, for the test of the cluster path (tests/test_batch_cli.cpp, BatchSlurm):
#   bash scripts/slurm-local.sh start   # as root: munge key, slurm.conf, munged, slurmctld, slurmd; waits until idle
#   bash scripts/slurm-local.sh stop    # stops the daemons by their pid files
# The node is this machine (its short host name, its cores, 90% of its memory); one partition,
# "odyssey", the default. No cgroups (proctrack/linuxproc, task/none), so it runs in containers.
# Everything it writes lives under $ODYSSEY_SLURM_DIR (default /var/lib/odyssey-slurm), except
# /etc/slurm/slurm.conf and /etc/munge/munge.key, where the daemons and the clients look for them;
# it refuses to overwrite a slurm.conf it did not write.
set -euo pipefail
state=${ODYSSEY_SLURM_DIR:-/var/lib/odyssey-slurm}
conf=/etc/slurm/slurm.conf
marker="# written by odyssey scripts/slurm-local.sh"

stop() {
  for daemon in slurmd slurmctld munged; do
    if [ -f "$state/$daemon.pid" ]; then
      kill "$(cat "$state/$daemon.pid")" 2>/dev/null || true
      rm -f "$state/$daemon.pid"
    fi
  done
}

start() {
  [ "$(id -u)" -eq 0 ] || { echo "slurm-local.sh: run as root (the daemons start as root)" >&2; exit 1; }
  for tool in munged slurmctld slurmd sinfo; do
    command -v "$tool" >/dev/null || { echo "slurm-local.sh: $tool is missing (apt-get install slurmctld slurmd slurm-client munge)" >&2; exit 1; }
  done
  if [ -f "$conf" ] && ! grep -qF "$marker" "$conf"; then
    echo "slurm-local.sh: $conf exists and is not ours; leaving it and the cluster it describes alone" >&2
    exit 1
  fi
  stop
  mkdir -p "$state"/{ctld,slurmd,log} /etc/slurm /etc/munge /run/munge /var/log/munge /var/lib/munge
  chown munge:munge /etc/munge /run/munge /var/log/munge /var/lib/munge
  if [ ! -s /etc/munge/munge.key ]; then
    dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 status=none
  fi
  chown munge:munge /etc/munge/munge.key
  chmod 0400 /etc/munge/munge.key
  # A munged that already answers (the system's) is used as it is.
  if ! munge -n 2>/dev/null | unmunge >/dev/null 2>&1; then
    runuser -u munge -- munged --pid-file=/run/munge/munged.pid
    cp /run/munge/munged.pid "$state/munged.pid"
  fi

  local host cpus memory_mb
  host=$(hostname -s)
  cpus=$(nproc)
  memory_mb=$(awk '/MemTotal/ { printf "%d", $2 / 1024 * 0.9 }' /proc/meminfo)
  cat > "$conf" <<EOF
$marker
ClusterName=odyssey
SlurmctldHost=$host
SlurmUser=root
AuthType=auth/munge
StateSaveLocation=$state/ctld
SlurmdSpoolDir=$state/slurmd
SlurmctldPidFile=$state/slurmctld.pid
SlurmdPidFile=$state/slurmd.pid
SlurmctldLogFile=$state/log/slurmctld.log
SlurmdLogFile=$state/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
SchedulerType=sched/backfill
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MpiDefault=none
ReturnToService=2
SchedulerParameters=defer_batch
NodeName=$host CPUs=$cpus RealMemory=$memory_mb State=UNKNOWN
PartitionName=odyssey Nodes=$host Default=YES MaxTime=INFINITE State=UP
EOF
  slurmctld
  slurmd
  for _ in $(seq 60); do
    if sinfo -h -o %T 2>/dev/null | grep -qE '^(idle|mixed|allocated)'; then
      echo "slurm-local.sh: one-node cluster up: $host, $cpus CPUs, $memory_mb MB, partition odyssey"
      return 0
    fi
    sleep 1
  done
  echo "slurm-local.sh: the node did not come up in 60 s; logs in $state/log" >&2
  sinfo >&2 || true
  exit 1
}

case "${1:-}" in
  start) start ;;
  stop) stop ;;
  *) echo "usage: $0 start|stop" >&2; exit 2 ;;
esac
