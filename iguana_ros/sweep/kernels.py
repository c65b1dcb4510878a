"""Kernel warm-up of a sweep worker: every JIT kernel a sweep task runs, compiled or loaded from the on-disk
cache once per process, under the kernel-cache lock (one process at a time; see iguana_ros.jit)."""
from __future__ import annotations

import functools
import time

from iguana_ros.jit import ensure_fresh_kernel_cache, kernel_cache_lock


def _warm_direct_solver() -> None:
    """One frame of the simulator with the direct solver (the frame loop of `iguana warm` uses CG)."""
    from iguana_ros.bench.workload import bench_model
    from iguana_ros.physics.simulator import SoftBodySimulator
    from iguana_ros.terrain.heightfield import HeightField

    model, _ = bench_model('coarse')
    SoftBodySimulator(model, HeightField.flat(), 'balanced', solver='direct').advance_frame(None)


@functools.lru_cache(maxsize=None)
def warm_kernels() -> float:
    """Compile or load the kernels of every sweep task (the frame loop of `iguana warm`, and the direct solver's
    step), holding the kernel-cache lock; the seconds it took (done once per process, later calls return the
    first figure)."""
    from iguana_ros.warmup import warm_loop

    start = time.perf_counter()
    ensure_fresh_kernel_cache()
    with kernel_cache_lock():
        warm_loop()
        _warm_direct_solver()
    return time.perf_counter() - start
