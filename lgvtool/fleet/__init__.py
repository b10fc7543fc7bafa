"""Fleet scale: parameter sweeps over many logs and seeds on Dask (``lgvtool sweep``).

- :mod:`lgvtool.fleet.engine`: run any task function over many tasks on a local or remote
  Dask cluster, streaming outcomes (:func:`~lgvtool.fleet.engine.run_tasks`);
- :mod:`lgvtool.fleet.keys`: content hashes of logs and task keys;
- :mod:`lgvtool.fleet.tasks`: the sweep's tasks (logs x settings x seeds) and the work of one;
- :mod:`lgvtool.fleet.results`: per-task result files, the tidy table and the summary;
- :mod:`lgvtool.fleet.stats`: mean, std and Student-t intervals;
- :mod:`lgvtool.fleet.sweep_report`: the sweep's report.html;
- :mod:`lgvtool.fleet.sweep_run`: :func:`~lgvtool.fleet.sweep_run.run_sweep`, what the command runs.

Nothing here imports Dask, pandas or plotly at import time of the package.
"""
