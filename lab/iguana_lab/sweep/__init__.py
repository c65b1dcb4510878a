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
Parameter sweeps on a distributed engine (Dask): specs, task expansion, the engine runner, results tables.

`engine` runs tasks on a Dask cluster (local by default), `scene_task` is one library-loop run, `benchmarks`
builds the tasks of the stability and speed-accuracy benchmarks, `spec` reads a sweep file into tasks,
`results` writes the table and plots. `iguana sweep` (iguana_lab/cli/sweep.py) is the command over them.
"""
