# A one-node Slurm on this machine, for tests/slurm/slurm_test.sh and bench/slurm/measure.sh:
# munged, slurmctld and slurmd with their configuration, key, state and logs under $work. Source
# it with $work set; it starts them, exports SLURM_CONF, and stops them when the shell exits.
# Exits 77 (skipped) where Slurm cannot be started: not root, or the daemons are not installed.

fail() {
    echo "FAIL: $*"
    for log in "$work"/log/*.log; do echo "--- $log"; tail -n 20 "$log"; done
    exit 1
}

for daemon in munged slurmctld slurmd sbatch scontrol squeue sinfo; do
    if ! command -v "$daemon" >/dev/null; then
        echo "SKIP: $daemon not installed (scripts/setup installs slurm-wlm and munge)"
        exit 77
    fi
done
if [[ $(id -u) != 0 ]]; then
    echo "SKIP: starting slurmd needs root"
    exit 77
fi

# Daemons a killed earlier run left behind (their pid files name them) go first.
for pidfile in "$work"/run/*.pid "$work"/munge/munged.pid; do
    [[ -s $pidfile ]] || continue
    pid=$(cat "$pidfile")
    if [[ $(cat "/proc/$pid/comm" 2>/dev/null) =~ ^(slurmctld|slurmd|munged)$ ]]; then
        kill "$pid"
    fi
done
rm -rf "$work"
mkdir -p "$work"/{munge,state,spool,log,run,out}
chmod 700 "$work/munge"
pids=()
stop() {
    local pid
    for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null; done
    for pid in "${pids[@]}"; do
        for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
        kill -9 "$pid" 2>/dev/null
    done
}
trap stop EXIT
trap 'exit 1' INT TERM HUP

# munged with its own key and socket.
dd if=/dev/urandom of="$work/munge/munge.key" bs=1024 count=1 status=none
chmod 400 "$work/munge/munge.key"
socket=$work/munge/munge.socket
munged --force --socket="$socket" --key-file="$work/munge/munge.key" \
    --pid-file="$work/munge/munged.pid" --log-file="$work/log/munged.log" \
    --seed-file="$work/munge/munged.seed" || fail "munged did not start"
pids+=("$(cat "$work/munge/munged.pid")")

# Free ports for this run (others may run a Slurm of their own on this machine).
read -r ctld_port slurmd_port < <(python3 -c '
import socket
s = [socket.socket() for _ in range(2)]
for x in s: x.bind(("127.0.0.1", 0))
print(*(x.getsockname()[1] for x in s))')
host=$(hostname -s)
export SLURM_CONF=$work/slurm.conf
cat >"$SLURM_CONF" <<CONF
ClusterName=rayclass-test
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$socket
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/run/slurmctld.pid
SlurmdPidFile=$work/run/slurmd.pid
SlurmctldLogFile=$work/log/slurmctld.log
SlurmdLogFile=$work/log/slurmd.log
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/none
SchedulerType=sched/backfill
MpiDefault=none
ReturnToService=2
MinJobAge=600
SlurmdTimeout=60
InactiveLimit=0
KillWait=5
NodeName=$host NodeAddr=127.0.0.1 CPUs=2 State=UNKNOWN
PartitionName=test Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF
slurmctld -i || fail "slurmctld did not start"
for _ in $(seq 50); do [[ -s $work/run/slurmctld.pid ]] && break; sleep 0.1; done
pids+=("$(cat "$work/run/slurmctld.pid")")
slurmd || fail "slurmd did not start"
for _ in $(seq 50); do [[ -s $work/run/slurmd.pid ]] && break; sleep 0.1; done
pids+=("$(cat "$work/run/slurmd.pid")")
for _ in $(seq 100); do
    [[ $(sinfo -h -n "$host" -o %t 2>/dev/null) == idle ]] && break
    sleep 0.2
done
[[ $(sinfo -h -n "$host" -o %t) == idle ]] || fail "the node did not come up: $(sinfo 2>&1)"
echo "Slurm up: node $host, slurmctld port $ctld_port"

