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
iguana_lab: the benchmarks, fault-injection suites and distributed sweeps of iguana_ros, beside the product.

`pip install -e ./lab` (run by `make install`) adds `iguana bench ...` and `iguana sweep ...` to the `iguana`
command through the `iguana_ros.commands` entry-point group; without it, iguana_ros has neither command nor Dask.
"""
from setuptools import find_packages, setup

setup(
    name='iguana_lab',
    version='0.1.0',          # iguana_ros's version (package.xml); test/lab/test_lab_package.py keeps them equal
    description='Benchmarks, fault suites and sweeps of iguana_ros (the lab; not needed to run the iguana).',
    license='Apache-2.0',
    packages=find_packages(include=['iguana_lab', 'iguana_lab.*']),
    package_data={'iguana_lab': ['sweeps/*.yaml']},
    python_requires='>=3.10',
    install_requires=[
        'iguana_ros',
        'mcap-ros2-support>=0.5',   # the reference reader of the bag fault suite (faults/bag_files.py)
        'dask>=2024.1',             # the sweep engine (iguana sweep): Dask's config and sizes ...
        'distributed>=2024.1',      # ... and its scheduler, workers, LocalCluster
    ],
    zip_safe=False,
    entry_points={'iguana_ros.commands': ['bench = iguana_lab.cli.bench', 'sweep = iguana_lab.cli.sweep']},
)
