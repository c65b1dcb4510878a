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

"""Named fidelity presets: the knobs that trade simulation speed for accuracy."""
from __future__ import annotations

from dataclasses import dataclass, fields, replace

from iguana_ros.constants import SIM_DT
from iguana_ros.errors import InputError

JACOBIAN_MAX_AGE = 1.0 / 300.0
"""Longest time (s) a system matrix is reused: `jacobian_every` is capped at this age (4 steps at 1/1200 s,
every step from dt = 1/300 s). Older matrices let stiff, rotating elements blow up (measured: the gait scene
diverged with a 1/120 s old matrix at dt = 1/600, and at dt = 1/60 with 10-step-old ones)."""

EXPLICIT_ELASTIC_LIMIT = 0.4
"""Largest h² λ_max(A⁻¹ K_e) at which `elastic_integration='auto'` evaluates the corotated FEM force explicitly: K_e the
FEM stiffness, A = M(1 + hα) + (hβ + h²) K_springs the rest state's system matrix without it (its stiffest springs
axial only, no contact: the softest A a step meets). An explicit force is stable up to h²λ ≈ 4 (symplectic Euler
with A / h² as the mass), so 0.4 leaves a ~8x margin. Measured (FEM forced explicit, no gravity, a 5 % squashed
start, 1 s at dt 1/1200): the medium body with E x 2500 (h²λ = 2.9) stays stable and from E x 3000 (3.5) diverges;
coarse stays stable up to E x 96 (32), and walks the bench gait on hills up to E x 50 (17). Shipped bodies: medium
1.2e-3 (normal) / 8.6e-4 (softer), fine 7.1e-4 / 5.3e-4 at dt 1/1200 and 2.5e-3 for medium at 1/300: the springs
(300 kN/m) carry the stiffness, the 10 kPa FEM only keeps elements from degenerating; coarse 0.34 (its thin tail's
springs run nearly along the tail, so a sideways mode of its tip is held by the FEM alone: explicit, every step).
Coarse at dt 1/200 (12), any body with E = 1e8 Pa (x 1e4) and dt 1/60 stay implicit. (It was 0.01, a 400x margin,
which kept coarse implicit at 1.7x the cost of explicit: issue 34.)"""

HELD_ELASTIC_LIMIT = 0.04
"""Largest (k h)² λ_max(A⁻¹ K_e) of an explicit FEM force held for k steps (`elastic_every`, 'auto'): a force
sampled every k h is stable up to (k h)² λ ≈ 4 as one step of k h is, so 0.04 keeps a 100x margin. Measured: held 4
steps on medium (dt 1/1200 and 1/300) and fine, trajectories within 0.5 mm of the implicit step over 0.5 s
(`test_elastic_integration`); held 6 (medium) and 8 (fine, its 15 fastest tets every step) at dt 1/1200, the gait's
error against dt 1/4800 unchanged (medium 58.6 / 9.9 -> 58.3 / 9.5 mm node RMS / COM, fine 20.7 / 16.9 -> 20.6 /
16.8; docs/RESULTS.md, "Speed at scale, fifth session")."""

MAX_ELASTIC_EVERY = 8
"""Most steps an explicit FEM force is held between evaluations: the largest k with (k h)² λ_max(A⁻¹ K_e) <=
HELD_ELASTIC_LIMIT, capped at 8 (at 4 the fine body spent ~70 us a step on its FEM, 12 % of its step; at 8, ~35)."""

ELASTIC_INTEGRATIONS = ('auto', 'implicit', 'explicit')
FACTOR_THREADS = ('off', 'on')
REFACTOR_RULES = ('age', 'amortised')
SOLVERS = ('cg', 'direct')
PRECONDITIONERS = ('jacobi', 'ssor', 'cholesky')
RESOLUTIONS = ('coarse', 'medium', 'fine')


@dataclass(frozen=True)
class Fidelity:
    """
    Integration settings.

    Time step (s), linear solver and CG preconditioner, CG tolerance/iterations, Jacobian refresh interval (steps),
    rotation-extraction iterations per step, and how long a Cholesky preconditioner factor is reused (`factor_every`
    steps; refactorised sooner once a solve needs more than `refactor_iters` CG iterations).

    `resolution` is the mesh resolution a scene or benchmark builds the model at (the simulator itself
    simulates whatever model it is given).

    `elastic_integration`: the corotated FEM force enters the implicit step with its stiffness blocks
    ('implicit', the paper's scheme), is evaluated at the step's start only ('explicit': no FEM blocks to
    assemble, 78 instead of 150 µs per step on medium), or 'auto': explicit where the FEM is negligible
    against the springs (EXPLICIT_ELASTIC_LIMIT), as on the shipped coarse, medium and fine bodies, and then evaluated
    every `elastic_every` steps and held in between (MAX_ELASTIC_EVERY).

    `refactor_rule`: 'age' refactorises the Cholesky preconditioner every `factor_every` steps or after a solve of more
    than `refactor_iters` CG iterations; 'amortised' also as soon as the iterations its solves needed beyond one each
    have cost as much as a factorisation (`CholeskyPattern.refactor_budget`: ~3 iterations on coarse and medium,
    ~8 on fine with the SIMD block kernels), with `factor_every` as the longest reuse: the factor is renewed as often
    as its cost is repaid, so a body whose factorisation is dear against an iteration (fine) keeps it longer, and a
    fast-changing matrix renews it sooner.

    `factor_rotation_every`: with the Cholesky preconditioner, every this many steps of a factor's age the rotations
    of the body's node clusters since its matrix are updated and the factor is applied turned by them (the corotated
    preconditioner, `physics.factor_rotation`): a reused factor then misses the body's deformation since its matrix
    but not its rotation, so CG needs fewer iterations and the factor lasts longer. 0: the factor as it is.

    `factor_thread`: 'on' computes the Cholesky preconditioner's factor due by age or by the 'amortised' budget on a
    second thread beside the step loop and uses it from `factor_lag` steps after its matrix (`physics.factor_thread`);
    'off' (default) in the loop. Deterministic either way; it pays only where a core is free (docs/RESULTS.md, "Speed
    at scale").
    """

    dt: float = SIM_DT
    solver: str = 'cg'
    preconditioner: str = 'jacobi'
    cg_tol: float = 1e-4
    cg_max_iter: int = 100
    jacobian_every: int = 1
    polar_iters: int = 8
    resolution: str = 'medium'
    factor_every: int = 1
    refactor_iters: int = 2
    elastic_integration: str = 'auto'
    factor_thread: str = 'off'
    refactor_rule: str = 'age'
    factor_rotation_every: int = 0

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
            (int(self.factor_every) >= 1, 'factor_every', 'an integer >= 1 (steps a Cholesky factor is reused)'),
            (int(self.refactor_iters) >= 1, 'refactor_iters', 'an integer >= 1 (CG iterations)'),
            (self.elastic_integration in ELASTIC_INTEGRATIONS, 'elastic_integration',
             f'one of {ELASTIC_INTEGRATIONS}'),
            (self.factor_thread in FACTOR_THREADS, 'factor_thread', f'one of {FACTOR_THREADS}'),
            (self.refactor_rule in REFACTOR_RULES, 'refactor_rule', f'one of {REFACTOR_RULES}'),
            (int(self.factor_rotation_every) >= 0, 'factor_rotation_every',
             "an integer >= 0 (steps between updates of the factor's rotations; 0 = off)"),
        ]
        for ok, name, expected in checks:
            if not ok:
                raise InputError(f'fidelity: {name} must be {expected}, got {getattr(self, name)!r}')
        return self


PRESETS = {
    # jacobian_every=1: the spring-dominated iguana presets (body/stiffness.py, leg springs ~1e5-1e6 N/m) diverge
    # with any reused matrix under an abrupt command (bench gait: 120 m/s at t=3 ms with every 2-4 steps).
    # preconditioner='cholesky': the block Cholesky factor of the matrix makes CG converge in 1 iteration;
    # measured 1.9x (medium) and 1.5x (coarse) faster than block Jacobi's 62 / 37 iterations with these stiff
    # springs. factor_every: the factor (the largest single cost, ~200 us on medium) is reused for several steps;
    # the matrix itself stays current, CG absorbs the difference in a few iterations and the trajectory's error
    # against the dt=1/4800 reference is unchanged (dominated by the time step).
    # polar_iters=1: the rotations are warm-started from the last step, so one iteration per step tracks them
    # (the 8 of before cost 0.22 ms/step for no measurable change in the error).
    # elastic_integration 'auto' (fast, balanced): the FEM force explicit where the springs carry the stiffness
    # (medium, fine), 150 -> 78 us of FEM per step on medium, trajectories within 0.5 mm of the implicit step over
    # 0.5 s (test_elastic_integration); 'accurate' keeps the paper's fully implicit step.
    # fast: dt 1/200 walks like 1/300 (hills goal 13.3 vs 13.4 s, flat_walk 8.37 vs 8.37 s; slip 0.116 vs 0.099 m
    # on hills, 0.082 vs 0.066 m on flat_walk) at 1.4x the speed; 1/150 misses the hills goal (0.16 m slip, stuck).
    # factor_every 2: at 1/200 the matrix moves more per step; 2 costs 10 % less than 4 (2.3 vs 2.4 CG iterations).
    # Matrix age cap: every step from 1/300. balanced: factor_every 8 with refactor_iters 3, since the matrix-free
    # step (springs' stiffness applied on the fly) made a CG iteration cheaper against a factorisation plus its
    # assembly: 11 % less per step than 4 / 2 (1.6 CG iterations, a factorisation every 7.4 steps); the error is
    # the CG tolerance's, unchanged (docs/RESULTS.md, trade-off table). Then (issue 34) refactor_rule 'amortised',
    # factor_every 16 as the longest reuse: a factorisation once the extra CG iterations have cost as much (budget ~4.5
    # iterations on coarse and medium, ~14 on fine): fine 7 % faster (a factorisation every 12 instead of 7.8 steps),
    # coarse and medium as before (their budget keeps them near every 7-8 steps). With the SIMD block kernels
    # (block_simd) a factorisation is cheaper against an iteration: budgets ~3 (coarse, medium) and ~8 (fine), a
    # factorisation every ~6-8 (coarse, medium) and ~11 (fine) steps. factor_rotation_every 4 (issue 34, sixth
    # session): the reused factor turned with the body's node clusters (physics.factor_rotation), updated every 4 steps
    # of its age: fine 1.65 -> 1.39 CG iterations and 0.088 -> 0.068 factorisations per step, 574 -> 528 us/step (in
    # one process, alternating on one state); medium and coarse unchanged within 1 % (their factor is cheap).
    'fast': Fidelity(dt=1.0 / 200.0, preconditioner='cholesky', cg_tol=1e-2, cg_max_iter=100, jacobian_every=1,
                     polar_iters=1, factor_every=2),
    'balanced': Fidelity(dt=SIM_DT, preconditioner='cholesky', cg_tol=1e-2, cg_max_iter=200, jacobian_every=1,
                         polar_iters=1, factor_every=16, refactor_iters=3, refactor_rule='amortised',
                         factor_rotation_every=4),
    'accurate': Fidelity(dt=1.0 / 2400.0, preconditioner='cholesky', cg_tol=1e-4, cg_max_iter=500,
                         jacobian_every=1, polar_iters=20, factor_every=1, elastic_integration='implicit'),
}
"""Named presets; their measured speed and error are in docs/RESULTS.md ("Simulator")."""


def get_fidelity(preset='balanced', **overrides) -> Fidelity:
    """Return a validated `Fidelity` from a preset name (or a `Fidelity`) with field overrides (None = keep)."""
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
