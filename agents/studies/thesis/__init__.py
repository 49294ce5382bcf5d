"""The thesis's estimator experiments replayed in FlowNav: configs (:mod:`.configs`), camera paths
(:mod:`.paths`), playback through the estimators (:mod:`.playback_runs`), metrics (:mod:`.metrics`), figures
(:mod:`.figures`), the five experiments (:mod:`.experiments`) and the README they write (:mod:`.report`)."""
