"""Speed benchmarks that write their tables, CSVs and plots: the estimator per stage (:mod:`.estimator_speed`,
:mod:`.estimator_speed_report`), the env per step (:mod:`.env_speed`, :mod:`.env_speed_report`) and whole
training recipes (:mod:`.recipe_speed`, :mod:`.recipe_speed_report`), on a scripted flight (:mod:`.flight`);
depth yield and accuracy per estimator setting (:mod:`.depth_yield`). Reports render the Jinja2 templates in
``templates/`` (:mod:`agents.common.jinja_reports`)."""
