#!/usr/bin/env bash
# Flies planner, planner_camera and planner_camera_observed on 20 validation layouts from
# CAMERA_REFERENCE_SEED_START (960300) of the closed field (capsules across the whole +-6 m lateral bound), on the
# clean course (1 m/s, 0.12 capsules/m^2) and the hard one (2 m/s, 0.18), one process each, and records each
# run's CPU seconds (user + system) beside its episodes. Run from the repository root.
set -euo pipefail
out=results/camera_reference
declare -A courses=(
  [clean]="--env field_width=12.0"
  [hard]="--env field_width=12.0 --env forward_speed=2.0 --env obstacle_density=0.18"
)
for course in clean hard; do
  for agent in planner planner_camera planner_camera_observed; do
    /usr/bin/time -o "$out/${agent}_${course}.time" -f "%U %S %e" \
      nice -n 10 python -c "import sys; from agents.cli import main; sys.exit(main())" evaluate \
      --agent "$agent" --episodes 20 --seed-start 960300 --env-id FlowNav-v0 ${courses[$course]} \
      --env depth_error_info=False --out "$out/${agent}_${course}.csv"
  done
done
