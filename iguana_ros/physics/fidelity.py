"""Named fidelity presets: the knobs that trade simulation speed for accuracy."""
from __future__ import annotations

from dataclasses import dataclass, fields, replace

from iguana_ros.constants import SIM_DT
from iguana_ros.errors import InputError

JACOBIAN_MAX_AGE = 1.0 / 300.0
"""Longest time (s) a system matrix is reused: `jacobian_every` is capped at this age (4 steps at 1/1200 s,
every step from dt = 1/300 s). Older matrices let stiff, rotating elements blow up (measured: the gait scene
diverged with a 1/120 s old matrix at dt = 1/600, and at dt = 1/60 with 10-step-old ones)."""

SOLVERS = ('cg', 'direct')
PRECONDITIONERS = ('jacobi', 'ssor', 'cholesky')
RESOLUTIONS = ('coarse', 'medium', 'fine')


@dataclass(frozen=True)
class Fidelity:
    """Integration settings: time step (s), linear solver and CG preconditioner, CG tolerance/iterations,
    Jacobian refresh interval (steps), rotation-extraction iterations per step.

    `resolution` is the mesh resolution a scene or benchmark builds the model at (the simulator itself
    simulates whatever model it is given).
    """

    dt: float = SIM_DT
    solver: str = 'cg'
    preconditioner: str = 'jacobi'
    cg_tol: float = 1e-4
    cg_max_iter: int = 100
    jacobian_every: int = 1
    polar_iters: int = 8
    resolution: str = 'medium'

    @property
    def effective_jacobian_every(self) -> int:
        """`jacobian_every` capped so that a system matrix is never older than JACOBIAN_MAX_AGE."""
        return max(1, min(int(self.jacobian_every), int(JACOBIAN_MAX_AGE / self.dt + 1e-9)))

    def validated(self) -> 'Fidelity':
        """Self, or InputError naming the bad field and what it expects."""
        checks = [
            (0 < self.dt <= 0.05, 'dt', 'a time step in (0, 0.05] s'),
            (self.solver in SOLVERS, 'solver', f'one of {SOLVERS}'),
            (self.preconditioner in PRECONDITIONERS, 'preconditioner', f'one of {PRECONDITIONERS}'),
            (0 < self.cg_tol < 1, 'cg_tol', 'a relative tolerance in (0, 1)'),
            (int(self.cg_max_iter) >= 1, 'cg_max_iter', 'an integer >= 1'),
            (int(self.jacobian_every) >= 1, 'jacobian_every', 'an integer >= 1 (steps between refreshes)'),
            (int(self.polar_iters) >= 1, 'polar_iters', 'an integer >= 1'),
            (self.resolution in RESOLUTIONS, 'resolution', f'one of {RESOLUTIONS}'),
        ]
        for ok, name, expected in checks:
            if not ok:
                raise InputError(f'fidelity: {name} must be {expected}, got {getattr(self, name)!r}')
        return self


PRESETS = {
    # jacobian_every=1: the spring-dominated iguana presets (body/stiffness.py, leg springs ~1e5-1e6 N/m) diverge
    # with any reused matrix under an abrupt command (bench gait: 120 m/s at t=3 ms with every 2-4 steps); a fresh
    # matrix each step costs about the same time here because CG then needs fewer iterations (measured).
    # preconditioner='cholesky': the block Cholesky factor of each step's matrix (CG converges in 1 iteration);
    # measured 1.9x (medium) and 1.5x (coarse) faster than block Jacobi's 62 / 37 iterations with these stiff
    # springs, and the trajectory is the exact solve's (block Jacobi at CG 1e-2 differed from it by 21 mm node RMS)
    'fast': Fidelity(dt=1.0 / 600.0, preconditioner='cholesky', cg_tol=1e-2, cg_max_iter=100, jacobian_every=1,
                     polar_iters=4),
    'balanced': Fidelity(dt=SIM_DT, preconditioner='cholesky', cg_tol=1e-2, cg_max_iter=200, jacobian_every=1,
                         polar_iters=8),
    'accurate': Fidelity(dt=1.0 / 2400.0, preconditioner='cholesky', cg_tol=1e-4, cg_max_iter=500,
                         jacobian_every=1, polar_iters=20),
}
"""Named presets; their measured speed and error are in the README ("Simulator")."""


def get_fidelity(preset='balanced', **overrides) -> Fidelity:
    """A validated `Fidelity` from a preset name (or a `Fidelity`) with field overrides (None = keep)."""
    if isinstance(preset, Fidelity):
        base = preset
    elif preset in PRESETS:
        base = PRESETS[preset]
    else:
        raise InputError(f'fidelity: unknown preset {preset!r}; choose one of {sorted(PRESETS)}')
    names = {f.name for f in fields(Fidelity)}
    unknown = set(overrides) - names
    if unknown:
        raise InputError(f'fidelity: unknown setting(s) {sorted(unknown)}; known: {sorted(names)}')
    return replace(base, **{k: v for k, v in overrides.items() if v is not None}).validated()
