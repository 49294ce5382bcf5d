"""Training learned agents: the run's config (:mod:`.config`), PPO from a config (:mod:`.ppo`) with its envs
(:mod:`.envs`), callbacks (:mod:`.callbacks`), files (:mod:`.outputs`, :mod:`.saved_models`) and record
(:mod:`.run_record`), shipping a run to the policies folder (:mod:`.shipping`, :mod:`.manifest`), per-episode
sensor randomisation (:mod:`.wrappers`) and learning curves (:mod:`.curves`)."""
