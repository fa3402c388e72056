#!/usr/bin/env bash
# After issue 39's standard grid (standard-order.sh) has finished: issue 40's perturbation panel
# at `standard`, one seed per design, two one-thread cells at a time in paired order (order.sh).
# Resumes finished and partial cells when run again.
cd /work/main
while pgrep -f "standard-order.sh" >/dev/null || pgrep -f "gridbin/joca cell" >/dev/null; do sleep 30; done
echo "$(date -u +%FT%TZ) start perturbation-panel"
docs/results/2026-11-27-panels/order.sh
echo "$(date -u +%FT%TZ) end perturbation-panel rc=$?"
