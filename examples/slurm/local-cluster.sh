#!/bin/sh
# A single-node Slurm cluster on this machine, for trying the job array (and for
# `cargo xtask farm --engine slurm`), from Debian's packages:
#   apt-get install --no-install-recommends slurmctld slurmd slurm-client munge
#   examples/slurm/local-cluster.sh start DIR   # writes DIR/slurm.conf, starts munged, slurmctld, slurmd
#   export SLURM_CONF=DIR/slurm.conf            # then sbatch/squeue talk to it
#   examples/slurm/local-cluster.sh stop DIR
# Process tracking by /proc (proctrack/linuxproc), no cgroups, no accounting; run as root.
set -eu
cmd=$1 dir=$(mkdir -p "$2" && cd "$2" && pwd)
host=$(hostname -s)
case "$cmd" in
start)
    mkdir -p "$dir/state" "$dir/spool"
    cat > "$dir/slurm.conf" <<CONF
ClusterName=spectrace
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
ReturnToService=2
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/slurmctld.pid
SlurmdPidFile=$dir/slurmd.pid
SlurmctldLogFile=$dir/slurmctld.log
SlurmdLogFile=$dir/slurmd.log
NodeName=$host NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=local Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
    export SLURM_CONF="$dir/slurm.conf"
    if [ ! -s /etc/munge/munge.key ]; then
        mkdir -p /etc/munge
        dd if=/dev/urandom of=/etc/munge/munge.key bs=1024 count=1 2>/dev/null
        chown munge:munge /etc/munge/munge.key 2>/dev/null || true
        chmod 400 /etc/munge/munge.key
    fi
    mkdir -p /run/munge /var/log/munge /var/lib/munge
    chown munge:munge /run/munge /var/log/munge /var/lib/munge 2>/dev/null || true
    pgrep -x munged >/dev/null || runuser -u munge -- munged || munged --force
    slurmctld -f "$SLURM_CONF"
    slurmd -f "$SLURM_CONF"
    # Wait until the node takes jobs.
    i=0
    until sinfo -h -o %t 2>/dev/null | grep -Eq '^(idle|mix|alloc)'; do
        i=$((i + 1))
        [ "$i" -lt 100 ] || { echo "slurm did not come up; see $dir/slurmctld.log, $dir/slurmd.log" >&2; exit 1; }
        sleep 0.2
    done
    echo "slurm up: export SLURM_CONF=$SLURM_CONF"
    ;;
stop)
    for pid in "$dir/slurmd.pid" "$dir/slurmctld.pid"; do
        [ -s "$pid" ] && kill "$(cat "$pid")" 2>/dev/null || true
    done
    echo "slurm stopped (munged left running)"
    ;;
*) echo "usage: $0 start|stop DIR" >&2; exit 2 ;;
esac
