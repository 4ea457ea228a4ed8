#!/usr/bin/env bash
# Start a single-node SLURM cluster on this machine (root; Debian slurm-wlm + munge),
# for the SLURM test and for trying profiles/slurm locally. See ../shared/docs/slurm-notes.md.
#
#   sudo bash scripts/slurm-up.sh      # prints the partition name on success
#   sudo bash scripts/slurm-down.sh    # stops what this script started (by pid files)
#
# Environment: FLIDAR_SLURM_STATE (state dir, default /var/tmp/flidar_uq_slurm),
#              FLIDAR_SLURM_PARTITION (default "flidar").
# Writes /etc/slurm/slurm.conf (refuses to overwrite one it did not write).
set -euo pipefail

STATE=${FLIDAR_SLURM_STATE:-/var/tmp/flidar_uq_slurm}
PARTITION=${FLIDAR_SLURM_PARTITION:-flidar}
CONF=/etc/slurm/slurm.conf
MARK="# written by flidar_uq scripts/slurm-up.sh"

die() { echo "slurm-up: $*" >&2; exit 1; }
[ "$(id -u)" = 0 ] || die "must run as root"
for t in munged munge unmunge slurmctld slurmd sinfo; do
  command -v "$t" >/dev/null 2>&1 || die "$t not found (scripts/system-deps.sh installs slurm-wlm and munge)"
done

mkdir -p "$STATE"/{ctld,spool,log}

# --- munge ------------------------------------------------------------------------
install -d -o munge -g munge -m 0755 /run/munge
if munge -n 2>/dev/null | unmunge >/dev/null 2>&1; then
  echo "slurm-up: munged already running; reusing it"
else
  [ -s /etc/munge/munge.key ] || die "/etc/munge/munge.key missing (reinstall munge)"
  # munged runs as user munge: its own pid file lives in /run/munge; copied to $STATE,
  # which is what slurm-down.sh uses to stop it
  runuser -u munge -- /usr/sbin/munged --pid-file=/run/munge/flidar_uq_munged.pid
  for _ in $(seq 50); do munge -n 2>/dev/null | unmunge >/dev/null 2>&1 && break; sleep 0.1; done
  munge -n | unmunge >/dev/null || die "munge -n | unmunge fails"
  cp /run/munge/flidar_uq_munged.pid "$STATE/munged.pid"
fi

# --- slurm.conf -------------------------------------------------------------------
if [ -e "$CONF" ] && ! grep -qF "$MARK" "$CONF"; then
  die "$CONF exists and was not written by this script; not touching it"
fi
HOST=$(hostname)
CPUS=$(nproc)
MEM=$(( $(free -m | awk '/^Mem:/{print $7}') * 9 / 10 ))
cat > "$CONF" <<CONFEOF
$MARK
ClusterName=flidar
SlurmctldHost=$HOST
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SwitchType=switch/none
MpiDefault=none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
StateSaveLocation=$STATE/ctld
SlurmdSpoolDir=$STATE/spool
SlurmctldPidFile=$STATE/slurmctld.pid
SlurmdPidFile=$STATE/slurmd.pid
SlurmctldLogFile=$STATE/log/slurmctld.log
SlurmdLogFile=$STATE/log/slurmd.log
ReturnToService=2
MinJobAge=600
NodeName=$HOST CPUs=$CPUS RealMemory=$MEM State=UNKNOWN
PartitionName=$PARTITION Nodes=$HOST Default=YES MaxTime=INFINITE State=UP
CONFEOF

# --- daemons ----------------------------------------------------------------------
pid_alive() { [ -s "$1" ] && kill -0 "$(cat "$1")" 2>/dev/null; }
pid_alive "$STATE/slurmctld.pid" || slurmctld
for _ in $(seq 50); do pid_alive "$STATE/slurmctld.pid" && break; sleep 0.2; done
pid_alive "$STATE/slurmd.pid" || slurmd
for _ in $(seq 150); do
  state=$(sinfo -h -n "$HOST" -o %T 2>/dev/null || true)
  case "$state" in
    idle*|mixed*|allocated*) break ;;
    down*|drain*) scontrol update nodename="$HOST" state=resume >/dev/null 2>&1 || true ;;
  esac
  sleep 0.2
done
case "$(sinfo -h -n "$HOST" -o %T 2>/dev/null)" in
  idle*|mixed*|allocated*) ;;
  *) die "node $HOST not idle: $(sinfo 2>&1 | tail -n +1); logs in $STATE/log" ;;
esac
echo "$PARTITION"
