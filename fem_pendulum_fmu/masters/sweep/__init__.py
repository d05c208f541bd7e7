"""Parameter sweeps and ensembles of the FMU on Dask: `fem-pendulum sweep` and `run_sweep`.

    samples.py   grid (--param NAME=V1,V2) or table (CSV) -> samples with stable ids
    run.py       one sample through the FMU with fmpy, on an instance a worker reuses (no Dask)
    figures.py   summary figures of a sample's time series
    loop_samples.py, loop_run.py, loop_command.py   --control: each sample the controller loop of
                 masters/control/ (controller parameters and set-points as axes), its metrics the figures
    worker.py    the FMUs loaded once per worker process (a Dask worker plugin) and the task functions
    driver.py    run_sweep: local cluster or --scheduler, retries, resume
    store.py     the output folder: parts while running, results.parquet and series.parquet at the end
    progress.py, plot.py, command.py   progress bar, summary PNG, the subcommand

The subcommand's module imports nothing of Dask, pandas or pyarrow until it
runs (the `sweep` extra), so `fem-pendulum --help` works without them.
"""

from .command import add_arguments, command

__all__ = ["add_arguments", "command"]
