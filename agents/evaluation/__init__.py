"""Scoring agents: one episode (:mod:`.episode`), running many episodes locally or on Ray (:mod:`.runner`), the
sensor-error sweep (:mod:`.sweep`), the suite and the leaderboard. Each flight scores and returns typed values;
the pages written from them are :mod:`agents.pages`'. Reading the episodes it writes, and their statistics, is
the analysis's (:mod:`agents.analysis`)."""
