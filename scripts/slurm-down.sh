#!/usr/bin/env bash
# Stop the daemons scripts/slurm-up.sh started, by the pid files it wrote (never by name).
set -euo pipefail
STATE=${FLIDAR_SLURM_STATE:-/var/tmp/flidar_uq_slurm}
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
echo "slurm-down: stopped"
