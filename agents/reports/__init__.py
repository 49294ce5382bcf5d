"""Every page of ``results/`` and how it is rebuilt: the report registry (what each page is written from and the
writer call that rebuilds it, or why it is not regenerated; ``flownav reports`` regenerates and compares them)
and the pages written over the studies' values (the benchmark, the README's results block, the thesis's
closed-loop paragraph, the flow gap, the error analysis, the rule resolution). It sits above the studies, whose
functions the registry calls; the templates and the wording are :mod:`agents.pages`'."""
