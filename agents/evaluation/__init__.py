"""Scoring agents: one episode (:mod:`.episode`), its CSV (:mod:`.records` for the rows and their identity,
:mod:`.csv_file` for the bytes on disk), rates and intervals (:mod:`.statistics`), running many episodes
locally or on Ray (:mod:`.runner`), the sensor-error sweep (:mod:`.sweep`, :mod:`.sweep_report`), gain tuning
(:mod:`.tuning`) and videos (:mod:`.video`)."""
