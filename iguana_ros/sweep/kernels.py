"""Kernel warm-up of a sweep worker: every JIT kernel a sweep task runs, compiled or loaded from the on-disk
cache once per process, under the kernel-cache lock (one process at a time; see iguana_ros.jit)."""
from __future__ import annotations

import functools
import time

from iguana_ros.jit import ensure_fresh_kernel_cache, kernel_cache_lock

WARMUP_FRAMES = 2
"""Frames of the warm-up run: the first compiles (or loads) the frame loop's kernels, the second checks them."""


def _warm_pipeline() -> None:
    """Two frames of the library loop on hills with adaptation and a push, coarse mesh, and their metrics."""
    from iguana_ros import pipeline
    from iguana_ros.run_metrics import metrics_of_run
    from iguana_ros.scene import GoalSpec, ModelSpec, PushSpec, Scene, TerrainSpec

    scene = Scene(name='warmup', terrain=TerrainSpec(kind='hills', extent=4.0), model=ModelSpec(resolution='coarse'),
                  goals=(GoalSpec(x=1.0),), pushes=(PushSpec(at=0.0),), duration=1.0)
    result = pipeline.run(scene, n_frames=WARMUP_FRAMES)
    metrics_of_run(result, scene)


def _warm_direct_solver() -> None:
    """One frame of the simulator with the direct solver (the frame loop above uses CG)."""
    from iguana_ros.bench.workload import bench_model
    from iguana_ros.physics.simulator import SoftBodySimulator
    from iguana_ros.terrain.heightfield import HeightField

    model, _ = bench_model('coarse')
    SoftBodySimulator(model, HeightField.flat(), 'balanced', solver='direct').advance_frame(None)


@functools.lru_cache(maxsize=None)
def warm_kernels() -> float:
    """Compile or load the kernels of every sweep task, holding the kernel-cache lock; the seconds it took (the
    work is done once per process, later calls return the first figure)."""
    start = time.perf_counter()
    ensure_fresh_kernel_cache()
    with kernel_cache_lock():
        _warm_pipeline()
        _warm_direct_solver()
    return time.perf_counter() - start
