"""The analysis of committed episodes, apart from flight: the record and its outcome (:mod:`.episode_record`),
the episodes CSV (:mod:`.records` for the rows and their identity, :mod:`.csv_file` for the bytes on disk),
rates and intervals (:mod:`.statistics`), per-seed tables (:mod:`.over_seeds`), paired comparisons
(:mod:`.paired`), and the error analysis's statistics: failure against depth quality (:mod:`.dose_response`)
and weaving (:mod:`.weaving`).

It imports neither MuJoCo, Gymnasium, the env nor the policies (an import-linter contract in pyproject.toml
keeps it so): a report over committed data needs only this and its template.
"""
