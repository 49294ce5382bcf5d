"""Studies that use the core (policies, training, evaluation) and write reports: the thesis replication
(``thesis/``), speed benchmarks (``perf/``), tuning the reactive agents, ablations of training levers, choosing
a run's policy, the error analysis and videos."""
