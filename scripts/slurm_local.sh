#!/usr/bin/env bash
# A private single-node Slurm cluster (munged + slurmctld + slurmd) in one folder, for trying and testing the
# Slurm path of scripts/vo_campaign.py on one machine (docs/campaigns.md). Debian 12 packages: munge slurmctld
# slurmd slurm-client (scripts/install_deps.sh installs them). Run as root (slurmd launches the jobs); no
# systemd needed: the daemons are started directly with their pid, log and socket files inside DIR, on free
# ports, so they do not touch /etc/slurm, /etc/munge or a Slurm/munge already running on the machine.
#
#   scripts/slurm_local.sh start DIR    creates DIR/{slurm.conf,munge/,spool/,state/,logs/}, starts the three
#                                       daemons, waits until the node "localhost" is idle and prints
#                                       "export SLURM_CONF=DIR/slurm.conf" (eval it, or export it yourself)
#   scripts/slurm_local.sh stop DIR     cancels the cluster's jobs, stops the daemons (by their pid files) and
#                                       removes everything in DIR but logs/ and slurm.conf
#   scripts/slurm_local.sh status DIR   prints the daemons' pids and `sinfo`; exit 0 when all three run
#
# start on a folder whose daemons still run (a previous instance left over) stops them first. Only processes
# whose command line names DIR are ever signalled. The node has the CPUs and memory that `slurmd -C` reports;
# ProctrackType linuxproc, TaskPlugin none, no accounting (job records go to DIR/logs/jobcomp.txt).
set -euo pipefail

usage() {
  echo "usage: $0 start|stop|status DIR" >&2
  exit 2
}
[ $# -eq 2 ] || usage
action="$1"
mkdir -p "$2"
DIR="$(cd "$2" && pwd)"
CONF="$DIR/slurm.conf"
export SLURM_CONF="$CONF"
DAEMONS=(slurmd slurmctld munged)  # stop order: reverse of the start order

pidfile() { echo "$DIR/run/$1.pid"; }

# Pid of a daemon of this instance, or nothing: the pid file must name a live process whose command line
# contains DIR (a recycled pid of some other process is never signalled).
live_pid() {
  local f pid
  f="$(pidfile "$1")"
  [ -s "$f" ] || return 0
  pid="$(tr -dc 0-9 <"$f")"
  [ -n "$pid" ] && [ -r "/proc/$pid/cmdline" ] || return 0
  if tr '\0' ' ' <"/proc/$pid/cmdline" | grep -qF "$DIR"; then echo "$pid"; fi
}

stop_daemon() {
  local pid
  pid="$(live_pid "$1")"
  if [ -n "$pid" ]; then
    kill -TERM "$pid" 2>/dev/null || true
    for _ in $(seq 1 50); do
      [ -d "/proc/$pid" ] || break
      sleep 0.2
    done
    if [ -d "/proc/$pid" ]; then
      echo "slurm_local: $1 ($pid) did not stop on SIGTERM, sending SIGKILL" >&2
      kill -KILL "$pid" 2>/dev/null || true
    fi
  fi
  rm -f "$(pidfile "$1")"
}

stop_all() {
  if [ -n "$(live_pid slurmctld)" ] && [ -n "$(live_pid munged)" ]; then
    # Running jobs first, so that no slurmstepd outlives slurmd.
    timeout 10 scancel --full --quiet --state=PENDING 2>/dev/null || true
    local jobs
    jobs="$(timeout 10 squeue -h -o %A 2>/dev/null | sort -u | tr '\n' ' ' || true)"
    if [ -n "${jobs// /}" ]; then
      # shellcheck disable=SC2086
      timeout 10 scancel --full $jobs 2>/dev/null || true
      for _ in $(seq 1 25); do
        [ -z "$(timeout 5 squeue -h -o %A 2>/dev/null || true)" ] && break
        sleep 0.2
      done
    fi
  fi
  for d in "${DAEMONS[@]}"; do stop_daemon "$d"; done
}

# Free TCP ports on the loopback interface (bound, then released; Slurm binds them right after).
free_ports() {
  /usr/bin/python3 - "$1" <<'EOF'
import socket, sys
socks = []
for _ in range(int(sys.argv[1])):
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    socks.append(s)
print(" ".join(str(s.getsockname()[1]) for s in socks))
EOF
}

write_conf() {
  local ctld_port="$1" slurmd_port="$2" user node_hw host
  user="$(id -un)"
  host="$(hostname -s)"
  # CPUs, sockets, cores, threads and memory as slurmd itself detects them (a node whose configuration
  # claims more than the hardware has is drained); NodeName replaced by the fixed name "localhost".
  node_hw="$(slurmd -C | head -1 | sed -e 's/^NodeName=[^ ]* //')"
  cat >"$CONF" <<EOF
# Private single-node cluster written by scripts/slurm_local.sh; every path is inside $DIR.
ClusterName=pvo-local
# slurmctld checks that it runs on the host named here: the short host name, reached on the loopback.
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$ctld_port
SlurmdPort=$slurmd_port
SlurmUser=$user
SlurmdUser=$user
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket=$DIR/munge/munge.socket.2
StateSaveLocation=$DIR/state
SlurmdSpoolDir=$DIR/spool/slurmd
SlurmctldPidFile=$(pidfile slurmctld)
SlurmdPidFile=$(pidfile slurmd)
SlurmctldLogFile=$DIR/logs/slurmctld.log
SlurmdLogFile=$DIR/logs/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
JobCompType=jobcomp/filetxt
JobCompLoc=$DIR/logs/jobcomp.txt
MpiDefault=none
SwitchType=switch/none
SchedulerType=sched/backfill
# Jobs get cores, not the whole node: a two-core node runs two one-CPU array tasks at once.
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
SlurmctldTimeout=30
SlurmdTimeout=60
InactiveLimit=0
KillWait=5
MinJobAge=300
MaxArraySize=100001
MaxJobCount=200000
NodeName=localhost NodeAddr=127.0.0.1 NodeHostname=localhost $node_hw State=UNKNOWN
PartitionName=local Nodes=localhost Default=YES MaxTime=INFINITE State=UP OverSubscribe=NO
EOF
}

start() {
  for tool in munged mungekey slurmctld slurmd sinfo; do
    command -v "$tool" >/dev/null || {
      echo "slurm_local: $tool not found: install munge slurmctld slurmd slurm-client" >&2
      exit 1
    }
  done
  stop_all  # a previous instance in this folder
  # Logs of a previous instance go too: job ids restart at 1, jobcomp.txt must list this instance's jobs only.
  rm -rf "$DIR/run" "$DIR/munge" "$DIR/spool" "$DIR/state" "$DIR/logs"
  mkdir -p "$DIR/run" "$DIR/munge" "$DIR/spool/slurmd" "$DIR/state" "$DIR/logs"
  # munged refuses key and socket folders that others may write to.
  chmod 0755 "$DIR"
  chmod 0700 "$DIR/munge"
  mungekey --create --keyfile="$DIR/munge/munge.key"
  chmod 0600 "$DIR/munge/munge.key"

  read -r ctld_port slurmd_port <<<"$(free_ports 2)"
  write_conf "$ctld_port" "$slurmd_port"

  # --force: munged otherwise refuses to run as root or below a world-writable (sticky) folder such as /tmp.
  munged --force --socket="$DIR/munge/munge.socket.2" --key-file="$DIR/munge/munge.key" \
    --pid-file="$(pidfile munged)" --log-file="$DIR/logs/munged.log" --seed-file="$DIR/munge/munged.seed"
  # -c: start from a clean state (no jobs or node states of an earlier instance).
  slurmctld -f "$CONF" -c
  slurmd -f "$CONF" -N localhost

  local state=""
  for _ in $(seq 1 150); do
    state="$(timeout 10 sinfo -h -N -n localhost -o %t 2>/dev/null || true)"
    case "$state" in
    idle*) break ;;
    drain* | down* | fail*) break ;;
    esac
    sleep 0.2
  done
  if [[ "$state" != idle* ]]; then
    echo "slurm_local: the node did not become idle (state '${state}'); logs in $DIR/logs:" >&2
    tail -n 20 "$DIR"/logs/*.log >&2 || true
    stop_all
    exit 1
  fi
  echo "slurm_local: cluster up (slurmctld port $ctld_port, slurmd port $slurmd_port, node localhost" \
    "idle)" >&2
  echo "export SLURM_CONF=$CONF"
}

status() {
  local ok=0 pid
  for d in munged slurmctld slurmd; do
    pid="$(live_pid "$d")"
    if [ -n "$pid" ]; then echo "$d: running (pid $pid)"; else
      echo "$d: not running"
      ok=1
    fi
  done
  if [ $ok -eq 0 ]; then timeout 10 sinfo || ok=1; fi
  return $ok
}

case "$action" in
start) start ;;
stop)
  stop_all
  rm -rf "$DIR/run" "$DIR/munge" "$DIR/spool" "$DIR/state"
  echo "slurm_local: stopped ($DIR)" >&2
  ;;
status) status ;;
*) usage ;;
esac
