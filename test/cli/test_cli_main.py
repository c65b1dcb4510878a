"""The `iguana` entry point: a reader that closes the pipe gets no traceback."""
import subprocess
import sys

CLOSED_PIPE = '''
import os, sys
read, write = os.pipe()
os.close(read)                       # nobody reads: the first flush of stdout raises BrokenPipeError
os.dup2(write, 1)
from iguana_ros.cli import main
sys.exit(main(['topics']))
'''


def test_a_closed_pipe_ends_quietly():
    """`iguana topics | head -1` once head has gone: exit 141 (128 + SIGPIPE) and nothing on stderr (before: a
    BrokenPipeError traceback)."""
    done = subprocess.run([sys.executable, '-c', CLOSED_PIPE], capture_output=True, text=True, timeout=60)
    assert done.returncode == 141, done.stderr[-2000:]
    assert 'Traceback' not in done.stderr
