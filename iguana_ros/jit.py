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
numba compilation settings of the package's kernels, and an on-disk kernel cache kept consistent with the sources.

numba (`@njit(cache=True)`) keys a cached kernel on the timestamp of the file that defines it, not on the files
of the kernels it calls: after an edit or upgrade of `forces.py`, the cached `integrator.run_steps_cg` would go
on running the old force code (seen here: a 15 % speed-up in `forces.py` did not show in the simulator until the
cache was deleted). `ensure_fresh_kernel_cache` hashes every package module that defines kernels and, when the
hash differs from the one stored beside the cache, deletes the package's cached kernels so they recompile.

Where the cache is follows numba's own choice (`numba_cache_folder`): `$NUMBA_CACHE_DIR` when set and writable, else
the `__pycache__` beside each module, else numba's user-wide cache folder; the stamp and the lock sit in the cache
folder of the package itself, so a cache in NUMBA_CACHE_DIR has its own stamp (and a read-only install can still
keep a fresh cache there).
"""
from __future__ import annotations

from collections.abc import Iterator, Mapping
import contextlib
from dataclasses import dataclass
import fcntl
import functools
import hashlib
import os
from pathlib import Path
import re
import tempfile

FASTMATH = {'arcp', 'reassoc', 'nsz'}
"""LLVM fast-math flags of the force and factorisation kernels: reassociation, reciprocals, signed zeros; not
'nnan'/'ninf', so NaN and Inf still reach the simulator's finiteness checks, and not 'contract': with fused
multiply-adds a freshly compiled kernel and the same kernel loaded from numba's cache rounded differently
(1e-14 m after 2 s; a 25 s walk then reached its goal 0.9 s apart), breaking run-to-run determinism.
Measured 4 % faster steps on `medium`; the matrix-vector and triangular-solve kernels were slower with it."""

PACKAGE_DIR = Path(__file__).resolve().parent
STAMP_NAME = 'numba-sources.sha256'
LOCK_NAME = 'numba-compile.lock'


def nearest_existing(folder: Path) -> Path:
    """Return `folder` made absolute, or its nearest parent that exists (where creating it would start)."""
    probe = Path(folder).absolute()
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    return probe


def write_error(folder: Path) -> str:
    """
    Return '' if a file can be created in `folder` (in its nearest existing parent if it does not exist), else why not.

    The test is for real: permission bits say nothing to root or on a read-only mount, and a parent that is a file is
    found too ('/etc/hostname: Not a directory').
    """
    probe = nearest_existing(folder)
    try:
        with tempfile.TemporaryFile(dir=probe):
            return ''
    except OSError as exc:
        return f'{probe}: {exc.strerror or exc}'


def numba_modules(package_dir: Path = PACKAGE_DIR) -> list[Path]:
    """Modules under `package_dir` whose text mentions numba (those the source digest covers), sorted."""
    return sorted(p for p in package_dir.rglob('*.py') if b'numba' in p.read_bytes())


def numba_cache_folder(source_dir: Path, env: Mapping[str, str] | None = None) -> Path | None:
    """
    Return the folder where numba caches the kernels of the modules in `source_dir`, as its cache locators choose.

    `$NUMBA_CACHE_DIR/<dir>_<sha1 of the path>` when NUMBA_CACHE_DIR is set (in `env`, default this process's
    environment) and writable, else `source_dir/__pycache__` if writable, else the same subfolder of numba's user-wide
    cache (~/.cache/numba); None when none can be written (numba then caches nothing). numba itself is imported only
    when the answer is not `__pycache__`.
    """
    env = os.environ if env is None else env
    in_tree = Path(source_dir) / '__pycache__'
    if not env.get('NUMBA_CACHE_DIR') and not write_error(in_tree):
        return in_tree
    from numba.core.caching import _CacheLocator
    from numba.misc.appdirs import AppDirs

    sub = _CacheLocator.get_suitable_cache_subpath(str(Path(source_dir).absolute() / '_.py'))
    candidates = ([Path(env['NUMBA_CACHE_DIR']) / sub] if env.get('NUMBA_CACHE_DIR') else []) + [
        in_tree, Path(AppDirs(appname='numba', appauthor=False).user_cache_dir) / sub]
    return next((folder for folder in candidates if not write_error(folder)), None)


def cached_kernel_files(package_dir: Path = PACKAGE_DIR, env: Mapping[str, str] | None = None) -> list[Path]:
    """Every cached kernel file (`*.nbi`, `*.nbc`) of `package_dir`'s modules where numba keeps them for `env`."""
    folders = {numba_cache_folder(path.parent, env) for path in numba_modules(package_dir)}
    return sorted(f for folder in folders if folder is not None for pattern in ('*.nbi', '*.nbc')
                  for f in folder.glob(pattern))


def stamp_folder(package_dir: Path = PACKAGE_DIR, env: Mapping[str, str] | None = None) -> Path:
    """Return the folder of the source stamp and the compile lock: numba's cache folder of `package_dir` itself."""
    return numba_cache_folder(package_dir, env) or package_dir / '__pycache__'


def kernel_sources_digest(package_dir: Path = PACKAGE_DIR) -> str:
    """SHA-256 over the path and text of every module under `package_dir` that uses numba."""
    digest = hashlib.sha256()
    for path in numba_modules(package_dir):
        digest.update(str(path.relative_to(package_dir)).encode() + b'\0' + path.read_bytes())
    return digest.hexdigest()


def invalidate_stale_kernels(package_dir: Path = PACKAGE_DIR) -> int:
    """
    Delete cached kernels (`*.nbi`, `*.nbc`) under `package_dir` if its kernel sources changed since they were cached.

    Returns how many files were deleted (0 when fresh or when the cache is not writable).
    """
    cache_dir = stamp_folder(package_dir)
    try:
        cache_dir.mkdir(parents=True, exist_ok=True)
        stamp = cache_dir / STAMP_NAME
        with open(stamp, 'a+', encoding='ascii') as fh:
            fcntl.flock(fh, fcntl.LOCK_EX)               # one process of a launch checks and deletes, the rest wait
            fh.seek(0)
            digest = kernel_sources_digest(package_dir)
            if fh.read().strip() == digest:
                return 0
            removed = 0
            for cached in cached_kernel_files(package_dir):
                cached.unlink(missing_ok=True)
                removed += 1
            touch_kernel_sources(package_dir)
            fh.seek(0)
            fh.truncate()
            fh.write(digest)
            return removed
    except OSError:                                      # read-only install: numba then caches elsewhere or not
        return 0


def touch_kernel_sources(package_dir: Path = PACKAGE_DIR) -> None:
    """
    Give every module that uses numba a new modification time.

    numba accepts a cached kernel whose index records its own file's (mtime, size). A process that imported the
    modules before an edit and compiles a caller only after another process deleted the stale caches would save
    it with the caller file's unchanged stamp, compiled against the old callee, and it would then be loaded for
    good (seen here: a `run_steps_cg` cached that way moved the `hills` goal from 13.27 to 13.73 s). New stamps on
    every kernel file make numba itself refuse every entry recorded before the invalidation, however late it was
    written.
    """
    import time

    now = time.time_ns()
    for path in numba_modules(package_dir):
        stat = path.stat()
        os.utime(path, ns=(stat.st_atime_ns, max(now, stat.st_mtime_ns + 1000)))


@functools.lru_cache(maxsize=None)
def ensure_fresh_kernel_cache() -> int:
    """`invalidate_stale_kernels` for this package, once per process (call before the first kernel runs)."""
    return invalidate_stale_kernels()


@contextlib.contextmanager
def kernel_cache_lock(package_dir: Path = PACKAGE_DIR) -> Iterator[bool]:
    """
    Hold an exclusive lock on `package_dir`'s kernel cache for the `with` body (waiting for it).

    Yields whether the lock is held (False where the cache is not writable: nothing to protect then).

    numba writes each cache file atomically, but two processes compiling different signatures of one kernel at
    once may both take the next free data-file number, and the index of one then names the other's code. The
    processes of a sweep compile or load their kernels under this lock, one at a time (the later ones load).
    """
    try:
        cache_dir = stamp_folder(package_dir)
        cache_dir.mkdir(parents=True, exist_ok=True)
        fh = open(cache_dir / LOCK_NAME, 'a+', encoding='ascii')
    except OSError:
        yield False
        return
    with fh:
        fcntl.flock(fh, fcntl.LOCK_EX)
        try:
            yield True
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


KERNEL_DECORATOR = re.compile(rb'^\s*@(\w+\.)?njit\b', re.MULTILINE)
"""A line that decorates a compiled kernel."""


def kernel_modules(package_dir: Path | None = None) -> list[Path]:
    """Package modules that define compiled kernels, sorted."""
    root = Path(package_dir or PACKAGE_DIR)
    return sorted(p for p in root.rglob('*.py') if KERNEL_DECORATOR.search(p.read_bytes()))


@dataclass(frozen=True)
class KernelCache:
    """
    State of the compiled-kernel cache, where numba keeps it (see `numba_cache_folder`).

    The package's kernel modules, those without cached kernels for their current source (relative paths), those numba
    cannot cache anywhere, where the package's cache is ('' if nowhere), and why NUMBA_CACHE_DIR is not used when it is
    set but cannot be written ('' otherwise).
    """

    modules: tuple
    cold: tuple
    unwritable: tuple
    where: str = ''
    refused: str = ''

    @property
    def state(self) -> str:
        """'warm', 'cold' or 'partly warm (7 of 10)'."""
        if not self.cold:
            return 'warm'
        if len(self.cold) == len(self.modules):
            return 'cold'
        return f'partly warm ({len(self.modules) - len(self.cold)} of {len(self.modules)})'


def _cache_place(root: Path, env: Mapping[str, str]) -> tuple[str, str]:
    """Return (where numba caches `root`'s kernels for `env`, why a set NUMBA_CACHE_DIR is not used or '')."""
    folder = numba_cache_folder(root, env)
    wanted = env.get('NUMBA_CACHE_DIR', '')
    if folder is None:
        where = ''
    elif wanted and folder.is_relative_to(Path(wanted)):
        where = f'NUMBA_CACHE_DIR ({wanted})'
    else:
        where = "the package's __pycache__ folders" if folder == root / '__pycache__' else str(folder.parent)
    refused = write_error(Path(wanted)) if wanted and not where.startswith('NUMBA_CACHE_DIR') else ''
    return where, refused and f'NUMBA_CACHE_DIR={wanted} cannot be written ({refused})'


def kernel_cache(package_dir: Path | None = None, env: Mapping[str, str] | None = None) -> KernelCache:
    """Return the `KernelCache` of the package: cold unless its stamp matches the sources (see the module)."""
    env = os.environ if env is None else env
    root = Path(package_dir or PACKAGE_DIR)
    modules = kernel_modules(root)
    stamp = stamp_folder(root, env) / STAMP_NAME
    fresh = stamp.is_file() and stamp.read_text(encoding='ascii', errors='replace').strip() == \
        kernel_sources_digest(root)
    folders = {m: numba_cache_folder(m.parent, env) for m in modules}
    cached = [m for m in modules if folders[m] and any(folders[m].glob(f'{m.stem}.*.nbi'))] if fresh else []
    return KernelCache(tuple(modules), tuple(str(m.relative_to(root)) for m in modules if m not in cached),
                       tuple(m for m in modules if folders[m] is None), *_cache_place(root, env))
