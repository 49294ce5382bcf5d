"""Training learned agents: the run's config (:mod:`.config`), PPO from a config (:mod:`.ppo`), per-episode
sensor randomisation (:mod:`.wrappers`) and learning curves (:mod:`.curves`)."""
