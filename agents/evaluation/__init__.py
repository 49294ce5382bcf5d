"""Scoring agents: one episode (:mod:`.episode`), its CSV (:mod:`.records`), rates and intervals
(:mod:`.statistics`), running many episodes locally or on Ray (:mod:`.runner`), the sensor-error sweep
(:mod:`.sweep`, :mod:`.sweep_report`), gain tuning (:mod:`.tuning`) and videos (:mod:`.video`)."""
