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

"""The `iguana` entry point: a reader that closes the pipe gets no traceback."""
import subprocess
import sys

CLOSED_PIPE = """
import os, sys
read, write = os.pipe()
os.close(read)                       # nobody reads: the first flush of stdout raises BrokenPipeError
os.dup2(write, 1)
from iguana_ros.cli import main
sys.exit(main(['topics']))
"""


def test_a_closed_pipe_ends_quietly():
    """
    `iguana topics | head -1` once head has gone.

    Exit 141 (128 + SIGPIPE) and nothing on stderr (before: a BrokenPipeError traceback).
    """
    done = subprocess.run([sys.executable, '-c', CLOSED_PIPE], capture_output=True, text=True, timeout=60)
    assert done.returncode == 141, done.stderr[-2000:]
    assert 'Traceback' not in done.stderr
