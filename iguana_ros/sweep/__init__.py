"""Parameter sweeps on a distributed engine (Dask): specs, task expansion, the engine runner, results tables.

`engine` runs tasks on a Dask cluster (local by default), `scene_task` is one library-loop run, `benchmarks`
builds the tasks of the stability and speed-accuracy benchmarks, `spec` reads a sweep file into tasks,
`results` writes the table and plots. `iguana sweep` (iguana_ros/cli/sweep.py) is the command over them.
"""
