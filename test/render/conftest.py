"""Fixtures of the render tests."""
import pytest
from render_synthetic import write_synthetic_bag


@pytest.fixture(scope='session')
def synthetic_bag(tmp_path_factory):
    """A 2 s synthetic bag with mesh, odometry and scene markers (written once per session)."""
    return write_synthetic_bag(tmp_path_factory.mktemp('render') / 'synthetic')
