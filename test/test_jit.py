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

"""numba cache invalidation: an edited kernel source removes the package's cached kernels, an unchanged one not."""
from pathlib import Path

from iguana_ros.jit import invalidate_stale_kernels, kernel_sources_digest, STAMP_NAME


def _package(tmp_path: Path) -> Path:
    """Return a package with a kernel module calling a kernel of another module, and cached kernels of both."""
    pkg = tmp_path / 'pkg'
    (pkg / 'sub' / '__pycache__').mkdir(parents=True)
    (pkg / '__pycache__').mkdir()
    (pkg / 'callee.py').write_text('import numba\n@numba.njit(cache=True)\ndef f(x):\n    return x + 1\n')
    (pkg / 'sub' / 'caller.py').write_text('import numba\nfrom pkg.callee import f\n')
    (pkg / 'plain.py').write_text('X = 1\n')
    for name in ('sub/__pycache__/caller.g-3.py311.nbi', 'sub/__pycache__/caller.g-3.py311.1.nbc',
                 '__pycache__/callee.f-2.py311.nbi'):
        (pkg / name).write_bytes(b'cached')
    return pkg


def test_first_check_and_changed_callee_clear_the_cache_unchanged_sources_keep_it(tmp_path):
    pkg = _package(tmp_path)
    assert invalidate_stale_kernels(pkg) == 3                     # no stamp yet: caches of unknown sources
    assert (pkg / '__pycache__' / STAMP_NAME).read_text() == kernel_sources_digest(pkg)
    (pkg / 'sub' / '__pycache__' / 'caller.g-3.py311.nbi').write_bytes(b'recompiled')
    assert invalidate_stale_kernels(pkg) == 0                     # fresh: nothing deleted
    assert (pkg / 'sub' / '__pycache__' / 'caller.g-3.py311.nbi').exists()
    (pkg / 'plain.py').write_text('X = 2\n')                      # a module without kernels does not count
    assert invalidate_stale_kernels(pkg) == 0
    (pkg / 'callee.py').write_text('import numba\n@numba.njit(cache=True)\ndef f(x):\n    return x + 2\n')
    assert invalidate_stale_kernels(pkg) == 1                     # the caller's stale cache goes
    assert not list(pkg.rglob('*.nbi'))


def test_unwritable_cache_is_not_an_error(tmp_path):
    pkg = _package(tmp_path)
    (pkg / '__pycache__' / STAMP_NAME).mkdir()                    # the stamp cannot be opened as a file
    assert invalidate_stale_kernels(pkg) == 0


def test_invalidation_gives_every_kernel_module_a_new_stamp(tmp_path):
    """
    After a source change every kernel module gets a newer mtime; unchanged sources are left alone.

    Then numba refuses cache entries a racing process records later with the old stamps.
    """
    pkg = _package(tmp_path)
    invalidate_stale_kernels(pkg)
    kernels = [pkg / 'callee.py', pkg / 'sub' / 'caller.py']
    before = {p: p.stat().st_mtime_ns for p in kernels + [pkg / 'plain.py']}
    assert invalidate_stale_kernels(pkg) == 0
    assert all(p.stat().st_mtime_ns == before[p] for p in before)          # fresh: nothing touched
    (pkg / 'callee.py').write_text('import numba\n@numba.njit(cache=True)\ndef f(x):\n    return x + 3\n')
    edited = (pkg / 'callee.py').stat().st_mtime_ns
    invalidate_stale_kernels(pkg)
    assert (pkg / 'callee.py').stat().st_mtime_ns > edited
    assert (pkg / 'sub' / 'caller.py').stat().st_mtime_ns > before[pkg / 'sub' / 'caller.py']
    assert (pkg / 'plain.py').stat().st_mtime_ns == before[pkg / 'plain.py']
