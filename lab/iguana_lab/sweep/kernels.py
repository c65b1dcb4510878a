# Copyright 2026 iguana_ros developers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
Kernel warm-up of a sweep worker.

Every JIT kernel a sweep task runs, compiled or loaded from the on-disk cache once per process, under the kernel-cache
lock (one process at a time; see iguana_ros.jit).
"""
from __future__ import annotations

import functools
import time

from iguana_ros.jit import ensure_fresh_kernel_cache, kernel_cache_lock


@functools.lru_cache(maxsize=None)
def warm_kernels() -> float:
    """
    Compile or load the kernels of every sweep task (the frame loop of `iguana warm`, direct solver included).

    It holds the kernel-cache lock and returns the seconds it took (done once per process, later calls return the first
    figure).
    """
    from iguana_ros.warmup import warm_loop

    start = time.perf_counter()
    ensure_fresh_kernel_cache()
    with kernel_cache_lock():
        warm_loop()
    return time.perf_counter() - start
