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
The doctor: is this machine ready to run iguana_ros? One `Check` (a pass/fail line and its fix) per question.

`checks` holds the checks that need no ROS graph (Python, the ROS environment every command checks before rclpy,
rclpy and its RMW, caches, the bag folder, ffmpeg); `dds` the DDS loopback between two processes and the other
participants on the domain; `all_checks` here is the order `iguana doctor` asks them in.
"""
from __future__ import annotations

from pathlib import Path


def all_checks(timeout: float | None = None, resolution: str = 'medium', bags_dir: Path = Path('bags')) -> list:
    """Return every Check in order; the DDS checks only when the ROS environment and rclpy pass (else skipped)."""
    from iguana_ros.doctor import checks as doctor
    from iguana_ros.errors import InputError

    if timeout is not None and not timeout > 0:
        raise InputError(f'--timeout is {timeout}; expected a positive number of seconds')
    ros = [*doctor.environment_checks(), doctor.check_rmw()]
    found = [doctor.check_python(), *ros]
    blocking = [c.name for c in ros if c.needed and not c.ok]
    if not blocking:
        from iguana_ros.doctor.dds import dds_checks
        from iguana_ros.ros.endpoints import RECORDER_NODE_NAME
        from iguana_ros.supervisor.loopback import LOOPBACK_TIMEOUT_S
        from iguana_ros.supervisor.run import NODE_KINDS
        found += dds_checks((*NODE_KINDS, RECORDER_NODE_NAME), timeout or LOOPBACK_TIMEOUT_S)
    else:
        first = ' and '.join(blocking)
        found += [doctor.Check(name, False, f'not tried: fix {first} first')
                  for name in ('DDS loopback', 'other participants')]
    return found + [doctor.check_kernel_cache(), doctor.check_model_cache(resolution),
                    doctor.check_bag_folder(bags_dir), doctor.check_ffmpeg()]
