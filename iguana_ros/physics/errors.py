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
