#!/usr/bin/env bash
# Install the Debian packages the cluster and browser tests need (SLURM, munge,
# headless Chromium). Idempotent; does nothing when they are present or when we are
# not root with apt-get (those tests then skip locally, and fail under CI=true).
set -euo pipefail
need=()
command -v slurmctld >/dev/null 2>&1 || need+=(slurm-wlm)
command -v munged    >/dev/null 2>&1 || need+=(munge)
command -v chromium  >/dev/null 2>&1 || need+=(chromium)
[ ${#need[@]} -eq 0 ] && { echo "system-deps: all present"; exit 0; }
if [ "$(id -u)" != 0 ] || ! command -v apt-get >/dev/null 2>&1; then
  echo "system-deps: missing ${need[*]} (not root/apt); SLURM and browser tests will skip" >&2
  exit 0
fi
echo "system-deps: installing ${need[*]}"
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${need[@]}" >/dev/null
