"""ament_python package for iguana_ros; also installs with `pip install -e .[ros,test]`."""
from pathlib import Path

from setuptools import find_packages, setup

PACKAGE = 'iguana_ros'
HERE = Path(__file__).resolve().parent


def _data_files() -> list:
    """Install msg_configs/ (topics, params, scenes) under share/iguana_ros/, keeping folders."""
    files = [
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE]),
        ('share/' + PACKAGE, ['package.xml']),
    ]
    by_dir: dict = {}
    for path in sorted((HERE / 'msg_configs').rglob('*')):
        if path.is_file() and '__pycache__' not in path.parts:
            rel = path.relative_to(HERE)
            by_dir.setdefault(str(Path('share') / PACKAGE / rel.parent), []).append(str(rel))
    files.extend(sorted(by_dir.items()))
    return files


NODES = ['planner_node', 'terrain_adaptation_node', 'spring_length_node', 'simulator_node']
_node_scripts = [
    f'{name}=iguana_ros.nodes.{name}:main'
    for name in NODES
    if (HERE / PACKAGE / 'nodes' / f'{name}.py').exists()
]

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(exclude=['test', 'test.*', 'benchmarks']),
    package_data={PACKAGE: ['data/*', 'data/capture/*']},
    data_files=_data_files(),
    python_requires='>=3.10',
    install_requires=[
        'numpy>=1.24',
        'scipy>=1.10',
        'pyyaml>=6',
        'numba>=0.59',
        'mcap>=1.1',
        'mcap-ros2-support>=0.5',
        'zstandard>=0.21',
        'c3d>=0.5',
        'matplotlib>=3.7',
        'imageio>=2.31',
        'imageio-ffmpeg>=0.4.9',
        'tqdm>=4.60',
        'psutil>=5.9',
        'threadpoolctl>=3.1',
    ],
    extras_require={
        # ROS 2 Jazzy from PyPI wheels; on a machine with ROS 2 installed these come from apt.
        'ros': ['ros-jazzy-rclpy', 'ros-jazzy-common-interfaces', 'ros-jazzy-rmw-fastrtps-cpp'],
        'test': ['pytest>=7', 'pytest-timeout>=2.1'],
    },
    zip_safe=False,
    maintainer='iguana_ros developers',
    maintainer_email='dev@iguana-ros.invalid',
    description='Soft-body iguana character controller as ROS 2 nodes (Kwon et al. 2018).',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={'console_scripts': ['iguana=iguana_ros.cli:main'] + _node_scripts},
)
