"""Speed benchmarks that write their tables, CSVs and plots: the estimator per stage (:mod:`.estimator`,
:mod:`.estimator_report`) and the env per step (:mod:`.env`, :mod:`.env_report`), on a scripted flight
(:mod:`.flight`)."""
