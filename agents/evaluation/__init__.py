"""Scoring agents: one episode (:mod:`.episode`), running many episodes locally or on Ray (:mod:`.runner`), the
sensor-error sweep (:mod:`.sweep`, :mod:`.sweep_report`), the suite and the leaderboard. Reading the episodes it
writes, and their statistics, is the analysis's (:mod:`agents.analysis`)."""
