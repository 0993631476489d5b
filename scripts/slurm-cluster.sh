#!/usr/bin/env bash
# A real one-node Slurm cluster on localhost, every file under one folder, no systemd.
#
#   scripts/slurm-cluster.sh install        install Debian's slurm and munge packages (root)
#   scripts/slurm-cluster.sh start DIR      write DIR/etc/slurm.conf, start munged, slurmctld and
#                                           slurmd, wait until the node is idle; prints the line
#                                           `export SLURM_CONF=DIR/etc/slurm.conf`
#   scripts/slurm-cluster.sh stop DIR       stop the daemons started in DIR (reverse order)
#
# Environment: SLURM_PORT (default 6817; slurmd uses SLURM_PORT+1): two clusters at once need
# different ports. Needs root (SlurmUser=root) and the `munge` user the package creates.
# It is what tests/slurm_cluster.rs and .ci/run use; see ../shared/NOTES-scale.md for the facts
# behind every setting (no cgroups here: proctrack/linuxproc, task/none).
set -euo pipefail

die() { echo "slurm-cluster: $*" >&2; exit 1; }

# Waits up to $1 tenths of a second for the command after it to succeed.
wait_for() {
    local tries=$1; shift
    for ((i = 0; i < tries; i++)); do
        if "$@" >/dev/null 2>&1; then return 0; fi
        sleep 0.1
    done
    return 1
}

install_packages() {
    [ "$(id -u)" = 0 ] || die "install needs root"
    if command -v slurmctld >/dev/null && command -v slurmd >/dev/null && command -v sbatch >/dev/null \
        && command -v munged >/dev/null; then
        echo "slurm-cluster: slurm and munge already installed"
        return
    fi
    # A policy-rc.d that exits 101 keeps the packages from starting their own services.
    if [ ! -e /usr/sbin/policy-rc.d ]; then
        printf '#!/bin/sh\nexit 101\n' > /usr/sbin/policy-rc.d
        chmod 755 /usr/sbin/policy-rc.d
    fi
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -q >/dev/null
    apt-get install -y -q --no-install-recommends slurmctld slurmd slurm-client munge >/dev/null
    echo "slurm-cluster: installed $(slurmctld -V)"
}

start_cluster() {
    local dir=$1
    [ "$(id -u)" = 0 ] || die "start needs root (the cluster runs its daemons as root)"
    for cmd in munged munge unmunge slurmctld slurmd sinfo scontrol setpriv; do
        command -v "$cmd" >/dev/null || die "$cmd not found: run '$0 install' first"
    done
    id munge >/dev/null 2>&1 || die "no munge user: run '$0 install' first"
    mkdir -p "$dir"
    dir=$(cd "$dir" && pwd)
    [ -e "$dir/pids" ] && die "$dir already has a cluster (stop it first)"
    local port=${SLURM_PORT:-6817}
    local host
    host=$(hostname -s)
    mkdir -p "$dir"/{etc,state,spool,log,munge,run}
    chmod 755 "$dir"
    # munged runs as the munge user: every folder above its own must be world-traversable.
    local up=$dir
    while [ "$up" != / ]; do
        up=$(dirname "$up")
        [ "$(( 0$(stat -c %a "$up") & 1 ))" = 1 ] \
            || die "munged (user munge) cannot reach $dir: $up is not world-traversable (chmod o+x $up, or start the cluster elsewhere)"
    done

    # munge: a fresh key, readable by munge only; the socket folder must be world-executable.
    chown munge:munge "$dir/munge"
    chmod 755 "$dir/munge"
    head -c 1024 /dev/urandom > "$dir/munge/munge.key"
    chown munge:munge "$dir/munge/munge.key"
    chmod 400 "$dir/munge/munge.key"
    local socket=$dir/munge/munge.socket
    setpriv --reuid=munge --regid=munge --init-groups munged -F --socket="$socket" \
        --key-file="$dir/munge/munge.key" --pid-file="$dir/munge/munged.pid" \
        --seed-file="$dir/munge/munge.seed" --log-file="$dir/log/munged.log" \
        </dev/null >"$dir/log/munged.out" 2>&1 &
    echo "munged $!" > "$dir/pids"
    wait_for 50 test -S "$socket" || die "munged did not start: $(cat "$dir/log/munged.out" "$dir/log/munged.log" 2>/dev/null)"
    munge -S "$socket" -n | unmunge -S "$socket" >/dev/null || die "munge self-test failed"

    # The node line is what slurmd detects, plus its address.
    local node
    node=$(slurmd -C | head -n 1)
    cat > "$dir/etc/slurm.conf" <<EOF
# Written by scripts/slurm-cluster.sh: a one-node cluster under $dir.
ClusterName=hdrflow
SlurmctldHost=$host(127.0.0.1)
SlurmUser=root
SlurmdUser=root
SlurmctldPort=$port
SlurmdPort=$((port + 1))
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$socket
StateSaveLocation=$dir/state
SlurmdSpoolDir=$dir/spool
SlurmctldPidFile=$dir/run/slurmctld.pid
SlurmdPidFile=$dir/run/slurmd.pid
SlurmctldLogFile=$dir/log/slurmctld.log
SlurmdLogFile=$dir/log/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SwitchType=switch/none
MpiDefault=none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
SchedulerParameters=batch_sched_delay=0
MinJobAge=4
MailProg=/bin/true
KillWait=5
InactiveLimit=0
$node NodeAddr=127.0.0.1 State=UNKNOWN
PartitionName=debug Nodes=ALL Default=YES MaxTime=INFINITE State=UP
EOF
    export SLURM_CONF=$dir/etc/slurm.conf

    slurmctld -D -i -c </dev/null >"$dir/log/slurmctld.out" 2>&1 &
    echo "slurmctld $!" >> "$dir/pids"
    wait_for 100 sh -c 'scontrol ping | grep -q UP' \
        || die "slurmctld did not come up: $(tail -n 20 "$dir/log/slurmctld.log" "$dir/log/slurmctld.out" 2>/dev/null)"

    slurmd -D -N "$host" </dev/null >"$dir/log/slurmd.out" 2>&1 &
    echo "slurmd $!" >> "$dir/pids"
    wait_for 150 sh -c "sinfo -h -n '$host' -o %T | grep -qx idle" \
        || die "node $host not idle: $(sinfo -h -n "$host" -o %T 2>&1); $(tail -n 20 "$dir/log/slurmd.log" "$dir/log/slurmd.out" 2>/dev/null)"
    echo "export SLURM_CONF=$SLURM_CONF"
}

stop_cluster() {
    local dir=$1
    [ -f "$dir/pids" ] || { echo "slurm-cluster: nothing running in $dir"; return; }
    # Running jobs first (slurmstepd outlives its job by about a second), then the daemons in
    # reverse order of start.
    if [ -f "$dir/etc/slurm.conf" ]; then
        SLURM_CONF=$dir/etc/slurm.conf scancel --user=root >/dev/null 2>&1 || true
        wait_for 50 sh -c '! pgrep -x slurmstepd' || true
    fi
    local pids
    pids=$(tac "$dir/pids" | awk '{print $2}')
    for pid in $pids; do
        kill -TERM "$pid" 2>/dev/null || true
        wait_for 50 sh -c "! kill -0 $pid" || kill -KILL "$pid" 2>/dev/null || true
    done
    rm -f "$dir/pids"
}

case "${1:-}" in
    install) install_packages ;;
    start) [ $# = 2 ] || die "usage: $0 start DIR"; start_cluster "$2" ;;
    stop) [ $# = 2 ] || die "usage: $0 stop DIR"; stop_cluster "$2" ;;
    *) die "usage: $0 install | start DIR | stop DIR" ;;
esac
