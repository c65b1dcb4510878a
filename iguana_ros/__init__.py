"""iguana_ros: soft-body iguana character control (Kwon, Kim, Lee, IEEE Access 2018) for ROS 2."""
from __future__ import annotations


def package_version() -> str:
    """The version of package.xml (setup.py copies it into the distribution's metadata): the installed
    distribution's, else the one in package.xml beside a plain source tree."""
    from importlib.metadata import PackageNotFoundError, version
    try:
        return version('iguana_ros')
    except PackageNotFoundError:
        import xml.etree.ElementTree as ET
        from pathlib import Path
        return ET.parse(Path(__file__).resolve().parent.parent / 'package.xml').getroot().findtext('version')


def __getattr__(name: str) -> str:
    """`iguana_ros.__version__`, read when asked for (nothing is read at import)."""
    if name == '__version__':
        return package_version()
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
