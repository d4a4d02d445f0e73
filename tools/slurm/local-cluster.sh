#!/bin/bash
# A single-node Slurm cluster on this machine, on loopback only, for the
# bench's own tests and for trying the scripts of tools/slurm/ before a real
# cluster: munged, slurmctld and slurmd with every file under DIR, but
# munged's. Those (key, socket, pid, log) go to a private folder that this
# script makes under /tmp and removes at stop, since the munge user must reach
# them and DIR may lie under a folder only root can enter (/root is mode 0700).
#   tools/slurm/local-cluster.sh start DIR [CPUS]   prints "export SLURM_CONF=DIR/slurm.conf"
#   tools/slurm/local-cluster.sh stop DIR
# Needs root (slurmd runs jobs as their user) and Debian's slurmctld, slurmd,
# slurm-client and munge (tools/debian-packages.txt); util-linux's unshare. Ports: 16817 (slurmctld)
# and 16818 (slurmd) unless HDABENCH_SLURM_PORT_BASE gives another base.
set -euo pipefail
die() { echo "local-cluster.sh: $1" >&2; exit "${2:-1}"; }
[[ $# -ge 2 ]] || die "usage: local-cluster.sh start|stop DIR [CPUS]" 2
command=$1 dir=$(realpath -m "$2") cpus=${3:-$(nproc)}
base=${HDABENCH_SLURM_PORT_BASE:-16817}

stop() {
  for name in slurmd slurmctld; do
    [[ -f $dir/$name.pid ]] && kill "$(cat "$dir/$name.pid")" 2>/dev/null || true
  done
  local munge_dir=""
  [[ -f $dir/munge-dir ]] && munge_dir=$(cat "$dir/munge-dir")
  for _ in $(seq 50); do
    pgrep -f "$dir/slurm.conf" >/dev/null || break
    sleep 0.1
  done
  if [[ $munge_dir == /tmp/hdabench-munge.* && -d $munge_dir ]]; then
    [[ -f $munge_dir/munged.pid ]] && kill "$(cat "$munge_dir/munged.pid")" 2>/dev/null || true
    for _ in $(seq 50); do
      pgrep -f "$munge_dir/" >/dev/null || break
      sleep 0.1
    done
    rm -rf "$munge_dir"
  fi
  rm -f "$dir/munge-dir"
}

case $command in
  start)
    [[ $(id -u) == 0 ]] || die "must run as root" 2
    for program in munged mungekey slurmctld slurmd sinfo; do
      command -v "$program" >/dev/null || die "$program not found: install slurmctld slurmd slurm-client munge" 4
    done
    # Both daemons resolve the name localhost, and give up without it; a root
    # made by debootstrap has no /etc/hosts.
    getent hosts localhost >/dev/null ||
      die "the name localhost does not resolve (no 'localhost' line in /etc/hosts?): slurmctld and slurmd need it" 4
    mkdir -p "$dir/state" "$dir/spool" "$dir/log"
    stop  # what an earlier start left behind
    munge=$(mktemp -d /tmp/hdabench-munge.XXXXXX) || die "cannot make a folder under /tmp for munged" 4
    echo "$munge" > "$dir/munge-dir"
    chown munge:munge "$munge"
    chmod 755 "$munge"
    install -d -o munge -g munge -m 700 "$munge/key"
    runuser -u munge -- mungekey -c -f -k "$munge/key/munge.key" || { stop; die "mungekey failed" 4; }
    runuser -u munge -- munged --key-file="$munge/key/munge.key" --socket="$munge/munge.socket" \
      --pid-file="$munge/munged.pid" --log-file="$munge/munged.log" --seed-file="$munge/munged.seed" ||
      { stop; die "munged did not start (see $munge/munged.log)" 4; }
    cat > "$dir/slurm.conf" <<CONF
ClusterName=hdabench-local
SlurmctldHost=localhost(127.0.0.1)
SlurmctldPort=$base
SlurmdPort=$((base + 1))
AuthType=auth/munge
AuthInfo=socket=$munge/munge.socket
CredType=cred/munge
CommunicationParameters=NoInAddrAny,NoCtldInAddrAny
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
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
SchedulerType=sched/backfill
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
MpiDefault=none
ReturnToService=2
NodeName=localhost NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=bench Nodes=localhost Default=YES MaxTime=INFINITE State=UP
CONF
    export SLURM_CONF=$dir/slurm.conf
    # With NoInAddrAny the daemons listen on the address of the machine's host
    # name, which Debian's /etc/hosts gives as 127.0.1.1, where the clients'
    # localhost does not reach them: they run where the host name is
    # localhost (a UTS namespace of their own), when the kernel allows one.
    local_host=()
    if unshare --uts true 2>/dev/null; then local_host=(unshare --uts sh -c 'echo localhost >/proc/sys/kernel/hostname && exec "$0" "$@"'); fi
    "${local_host[@]}" slurmctld -f "$SLURM_CONF" ||
      { stop; die "slurmctld did not start (see $dir/log/slurmctld.log)" 4; }
    "${local_host[@]}" slurmd -f "$SLURM_CONF" -N localhost ||
      { stop; die "slurmd did not start (see $dir/log/slurmd.log)" 4; }
    # Each sinfo is bounded too: one that cannot reach slurmctld retries for
    # its MessageTimeout.
    deadline=$((SECONDS + 20))
    while ((SECONDS < deadline)); do
      if timeout 5 sinfo -h -o %T 2>/dev/null | grep -qx idle; then
        echo "export SLURM_CONF=$SLURM_CONF"
        exit 0
      fi
      sleep 0.2
    done
    stop
    die "the node did not come up idle in 20 s (see $dir/log/)" 4
    ;;
  stop) stop ;;
  *) die "usage: local-cluster.sh start|stop DIR [CPUS]" 2 ;;
esac
