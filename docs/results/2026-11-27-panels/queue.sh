#!/usr/bin/env bash
# The queue as it ran in sessions 33-35, kept as the record; since session 36 resume.sh is the queue.
# After issue 39's standard grid (standard-order.sh) has finished: issue 40's perturbation panel
# at `standard`, one seed per design, two one-thread cells at a time in paired order (order.sh),
# then what decides its mechanism (perturbation-mechanism.toml: AP50 with relative steps, AP50
# without the tie-break; calibrated, 12 cells), then the controllers panel (its AverageAE cells
# come first: they do not depend on which perturbation search becomes the default; stop it before
# its NeuralAE cells if the default changes; its NeuralAE cells in calibrated and blur x4 are the
# perturbation panel's paper cells, shared by share_cells.sh paper), then Table 1's baselines in
# the three scenarios issue 39's grid did not run (docs/results/2026-11-27-table1-again/
# table1-baselines.toml: they do not depend on ours' default), then the ablation panel (the
# paper's method and its Table 3 ablations, with the paper's search; its `joca` cells shared the
# same way). Resumes finished and partial cells when run again.
cd "$(dirname "${BASH_SOURCE[0]}")/../../.."
while pgrep -f "standard-order.sh" >/dev/null || pgrep -f "gridbin/joca cell" >/dev/null; do sleep 30; done
echo "$(date -u +%FT%TZ) start perturbation-panel"
docs/results/2026-11-27-panels/order.sh
echo "$(date -u +%FT%TZ) end perturbation-panel rc=$?"
echo "$(date -u +%FT%TZ) start perturbation-mechanism"
target/panelbin/joca experiment docs/results/2026-11-27-panels/perturbation-mechanism.toml \
  --preset standard --seeds 1 --jobs 2 --config docs/results/2026-11-27-panels/threads1.toml \
  --out runs/pert-mechanism
echo "$(date -u +%FT%TZ) end perturbation-mechanism rc=$?"
docs/results/2026-11-27-panels/share_cells.sh paper
echo "$(date -u +%FT%TZ) start controllers panel"
target/panelbin/joca experiment controllers --preset standard --seeds 1 --jobs 2 \
  --config docs/results/2026-11-27-panels/threads1.toml --out runs/ctrl-panel
echo "$(date -u +%FT%TZ) end controllers panel rc=$?"
echo "$(date -u +%FT%TZ) start table1 baselines"
target/panelbin/joca experiment docs/results/2026-11-27-table1-again/table1-baselines.toml \
  --preset standard --seeds 3 --jobs 2 --config docs/results/2026-11-27-panels/threads1.toml \
  --out runs/table1-baselines
echo "$(date -u +%FT%TZ) end table1 baselines rc=$?"
docs/results/2026-11-27-panels/share_cells.sh paper
echo "$(date -u +%FT%TZ) start ablation panel"
target/panelbin/joca experiment ablation-panel --preset standard --seeds 1 --jobs 2 \
  --config docs/results/2026-11-27-panels/threads1.toml --out runs/ablation-panel
echo "$(date -u +%FT%TZ) end ablation panel rc=$?"
