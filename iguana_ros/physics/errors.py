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

"""The simulator's failure: raised instead of returning NaN/Inf or runaway states."""
from __future__ import annotations

from iguana_ros.errors import IguanaError


class SimulationDiverged(IguanaError):
    """The soft-body simulation blew up; `cause` is one of 'nan', 'speed', 'penetration', 'solver'."""

    def __init__(self, cause: str, message: str, time: float = float('nan'), node: int = -1) -> None:
        super().__init__(message)
        self.cause = cause
        self.time = time
        self.node = node
