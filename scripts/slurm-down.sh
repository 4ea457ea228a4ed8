#!/usr/bin/env bash
# Stop the daemons scripts/slurm-up.sh started, by the pid files it wrote (never by name),
# and remove the slurm.conf it wrote (only one carrying its mark): a config naming a
# controller that no longer runs makes every `scontrol` wait ~9 s for it, and the SLURM
# executor plugin runs `scontrol show config` at every Snakemake start, whatever the
# executor. Environment: FLIDAR_SLURM_STATE (state dir, default /var/tmp/flidar_uq_slurm),
# FLIDAR_SLURM_CONF (default /etc/slurm/slurm.conf, the path slurm-up.sh writes).
set -euo pipefail
STATE=${FLIDAR_SLURM_STATE:-/var/tmp/flidar_uq_slurm}
CONF=${FLIDAR_SLURM_CONF:-/etc/slurm/slurm.conf}
MARK="# written by flidar_uq scripts/slurm-up.sh"
stop() {
  local f=$STATE/$1.pid
  [ -s "$f" ] || return 0
  local pid; pid=$(cat "$f")
  if kill -0 "$pid" 2>/dev/null; then
    kill "$pid"
    for _ in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.1; done
    kill -0 "$pid" 2>/dev/null && kill -9 "$pid"
  fi
  rm -f "$f"
}
stop slurmd
stop slurmctld
stop munged
if [ -f "$CONF" ] && grep -qF "$MARK" "$CONF"; then
  rm -f "$CONF"
fi
echo "slurm-down: stopped"
