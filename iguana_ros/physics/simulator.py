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
`SoftBodySimulator`: the iguana soft body of paper Section V stepped by linearised backward Euler.

Works with `iguana_ros.body.model.IguanaModel` or any object with the same attributes (e.g.
`iguana_ros.physics.meshes.SoftBodyMesh`). Deterministic: the same inputs give bitwise the same states.
"""
from __future__ import annotations

import numpy as np

from iguana_ros.body.feet import contact_offsets
from iguana_ros.constants import (
    CONTACT_DAMPING_RATIO, CONTACT_STIFFNESS, FRAME_RATE, FRICTION_COEFFICIENT, FRICTION_STIFFNESS, GRAVITY,
    MAX_NODE_SPEED, MAX_PENETRATION, RAYLEIGH_ALPHA, RAYLEIGH_BETA)
from iguana_ros.errors import InputError
from iguana_ros.geometry import matrix_to_quat, rigid_fit
from iguana_ros.jit import ensure_fresh_kernel_cache
from iguana_ros.physics import integrator as itg
from iguana_ros.physics.assembly import BlockPattern
from iguana_ros.physics.cholesky import CholeskyFactor, CholeskyPattern, empty_factor
from iguana_ros.physics.elastic_rates import elastic_rates, elastic_stiffness_ratio, ElasticRates
from iguana_ros.physics.errors import SimulationDiverged
from iguana_ros.physics.factor_rotation import node_clusters
from iguana_ros.physics.factor_thread import factor_lag, FactorThread
from iguana_ros.physics.fidelity import (EXPLICIT_ELASTIC_LIMIT, Fidelity, get_fidelity)
from iguana_ros.physics.forces import (contact_forces, CONTACT_NONE, corotated_elastic_forces, lame_parameters,
                                       shape_gradients)
from iguana_ros.physics.kernel_data import empty_state, kernel_constant, kernel_input, KernelModel
from iguana_ros.physics.solver import DirectSolver, PRECONDITIONER_CODES
from iguana_ros.terrain.heightfield import block_maxima

LENGTH_HOLDS = ('linear', 'zero')
"""How desired lengths change within a frame: ramped from the previous frame's (first-order hold) or stepped."""

_CAUSES = {itg.STATUS_NAN: 'nan', itg.STATUS_SPEED: 'speed', itg.STATUS_PENETRATION: 'penetration',
           itg.STATUS_SOLVER: 'solver'}


def friction_per_node(model, friction) -> np.ndarray:
    """Coulomb μ per node `(n_nodes,)` from a number, a `(n_nodes,)` array, or {tag: μ} over the default 1.0."""
    n = len(model.rest_positions)
    if friction is None:
        mu = np.full(n, FRICTION_COEFFICIENT)
    elif isinstance(friction, dict):
        mu = np.full(n, float(friction.get('default', FRICTION_COEFFICIENT)))
        for tag, value in friction.items():
            if tag == 'default':
                continue
            if tag not in model.node_tags:
                raise InputError(f'friction: unknown node tag {tag!r}; known: {sorted(model.node_tags)}')
            mu[np.asarray(model.node_tags[tag], dtype=bool)] = float(value)
    else:
        mu = np.broadcast_to(np.asarray(friction, dtype=np.float64), (n,)).copy()
    if not np.all(np.isfinite(mu)) or np.any(mu < 0):
        raise InputError('friction: every coefficient must be a finite number >= 0')
    return mu


def _springs_by_node(n_nodes: int, springs: np.ndarray) -> dict:
    """Return the springs at each node, ascending: `node_spring_ptr (n + 1,)`, `node_springs (2 n_springs,)` (CSR)."""
    ends = np.concatenate([springs[:, 0], springs[:, 1]])
    order = np.lexsort((np.tile(np.arange(len(springs)), 2), ends))
    ptr = np.zeros(n_nodes + 1, dtype=np.int64)
    np.add.at(ptr, ends + 1, 1)
    return {'node_spring_ptr': np.cumsum(ptr), 'node_springs': np.tile(np.arange(len(springs)), 2)[order]}


def _ascending_nodes(tets: np.ndarray, grads: np.ndarray) -> tuple:
    """
    Return each tet's nodes `(n_tets, 4)` in ascending order with their shape gradients `(n_tets, 4, 3)` moved along.

    The FEM force is invariant to relabelling. Every (a < b) stiffness block then lands untransposed in the
    upper-triangle storage, so the assembly branch is always predicted.
    """
    order = np.argsort(tets, axis=1, kind='stable')
    return (np.ascontiguousarray(np.take_along_axis(tets, order, axis=1)),
            np.ascontiguousarray(np.take_along_axis(grads, order[:, :, None], axis=1)))


class SoftBodySimulator:
    """
    Tetrahedral soft body with springs, corotated FEM, Rayleigh damping and height-field ground contact.

    `terrain` is a `HeightField` (None = no ground). `fidelity` is a preset name or `Fidelity`; `overrides`
    replace its fields (dt, solver, cg_tol, cg_max_iter, jacobian_every, polar_iters). With `cg_fallback`, a step
    whose CG solve fails (not converged within cg_max_iter, or breakdown) is solved directly instead.

    `length_hold` says how the 30 Hz desired lengths drive the steps of a frame: 'linear' (default) ramps them
    from the previous call's lengths to the new ones over the call's steps (a first-order hold), 'zero' holds
    the new ones from the first step. A stiff body under a zero-order hold is jerked every frame (measured on
    the walking medium body: the feet's summed horizontal ground force swings from +10 N to -7 N within each
    frame, against 0.0-0.6 N with the ramp), which makes planted feet slide.
    """

    def __init__(self, model, terrain=None, fidelity='balanced', *, friction=None, gravity: float = GRAVITY,
                 rayleigh_alpha: float = RAYLEIGH_ALPHA, rayleigh_beta: float = RAYLEIGH_BETA,
                 contact_stiffness: float = CONTACT_STIFFNESS, contact_damping_ratio: float = CONTACT_DAMPING_RATIO,
                 friction_stiffness: float = FRICTION_STIFFNESS, max_speed: float = MAX_NODE_SPEED,
                 max_penetration: float = MAX_PENETRATION, cg_fallback: bool = True, length_hold: str = 'linear',
                 **overrides) -> None:
        ensure_fresh_kernel_cache()
        if length_hold not in LENGTH_HOLDS:
            raise InputError(f'simulator: length_hold must be one of {LENGTH_HOLDS}, got {length_hold!r}')
        self.length_hold = length_hold
        self.model = model
        self.terrain = terrain
        self.fidelity: Fidelity = get_fidelity(fidelity, **overrides)
        self._build_model_arrays(model, terrain, friction)
        self._build_params(gravity, rayleigh_alpha, rayleigh_beta, contact_stiffness, contact_damping_ratio,
                           friction_stiffness, max_speed, max_penetration)
        self._build_state()
        self._direct = DirectSolver(self.pattern) if self.fidelity.solver == 'direct' else None
        self._fallback = DirectSolver(self.pattern) if cg_fallback else None
        self.revision = 0
        """Counts the changes of the body's state (`reset`, `advance_frame`): what is derived from it is current while
        this is unchanged."""
        self.reset()

    # ------------------------------------------------------------------------------------------ building
    def _build_model_arrays(self, model, terrain, friction) -> None:
        """Build static arrays of the compiled kernels (`self._model`, a KernelModel)."""
        rest = np.ascontiguousarray(model.rest_positions, dtype=np.float64)
        tets = np.ascontiguousarray(model.tets, dtype=np.int64)
        springs = np.ascontiguousarray(model.springs, dtype=np.int64).reshape(-1, 2)
        n = len(rest)
        if rest.ndim != 2 or rest.shape[1] != 3 or tets.ndim != 2 or tets.shape[1] != 4:
            raise InputError('simulator: model needs rest_positions (n, 3) and tets (m, 4)')
        try:
            grads, volume = shape_gradients(rest, tets)
        except ValueError as exc:
            raise InputError(f'simulator: model {exc}') from None
        tets, grads = _ascending_nodes(tets, grads)
        mu, lam = lame_parameters(np.broadcast_to(model.youngs_modulus, (len(tets),)), model.poisson_ratio)
        mass = np.ascontiguousarray(model.node_mass, dtype=np.float64)
        if mass.shape != (n,) or np.any(mass <= 0):
            raise InputError('simulator: model.node_mass must be (n_nodes,) positive masses in kg')
        self.pattern = BlockPattern.build(n, tets, springs)
        self.rest_positions = rest
        self.desired_lengths_rest = kernel_input(model.spring_rest_lengths)
        heights, ox, oy, spacing = terrain.kernel_args() if terrain is not None else (np.zeros((2, 2)), 0., 0., 1.)
        self.friction = friction_per_node(model, friction)
        self.contact_offset = contact_offsets(model)
        fields = {
            'mass': mass, 'tets': tets, 'shape_gradients': grads, 'volume': volume, 'mu': mu, 'lam': lam,
            'springs': springs,
            'spring_stiffness': np.broadcast_to(np.asarray(model.spring_stiffness, np.float64), (len(springs),)),
            'friction': self.friction, 'heights': heights, 'height_bounds': block_maxima(heights),
            'terrain_grid': np.array([ox, oy, spacing]),
            'row_ptr': self.pattern.row_ptr, 'cols': self.pattern.cols, 'diag': self.pattern.diag,
            'tet_blocks': self.pattern.tet_blocks, 'spring_blocks': self.pattern.spring_blocks,
            **_springs_by_node(n, springs),
            'contact_mass': np.maximum(mass, mass.mean()),      # light (sliver) nodes get the mean
            'contact_offset': self.contact_offset, **self._clusters(rest, springs)}
        self._model = KernelModel(**{name: kernel_constant(value, np.asarray(value).dtype)
                                     for name, value in fields.items()})

    def _clusters(self, rest: np.ndarray, springs: np.ndarray) -> dict:
        """Return the node clusters of the corotated preconditioner (`cluster_ptr`, `cluster_nodes`; none if unused)."""
        fid = self.fidelity
        if fid.factor_rotation_every > 0 and fid.preconditioner == 'cholesky' and fid.solver == 'cg':
            ptr, nodes = node_clusters(rest, springs)
        else:
            ptr, nodes = np.zeros(1, dtype=np.int64), np.zeros(0, dtype=np.int64)
        return {'cluster_ptr': ptr, 'cluster_nodes': nodes}

    def _build_params(self, gravity, alpha, beta, kn, zeta, kt, max_speed, max_depth) -> None:
        """Float/int parameter vectors of the compiled kernels."""
        fid = self.fidelity
        mass = self._model.mass
        fp = np.zeros(itg.N_FP)
        fp[itg.FP_DT] = fid.dt
        fp[itg.FP_ALPHA] = alpha
        fp[itg.FP_BETA] = beta
        fp[itg.FP_GZ] = -gravity
        fp[itg.FP_KN] = kn
        fp[itg.FP_CN] = 2.0 * zeta * np.sqrt(kn)
        fp[itg.FP_KT] = kt
        fp[itg.FP_CT] = 2.0 * zeta * np.sqrt(kt)
        fp[itg.FP_CG_TOL] = fid.cg_tol
        fp[itg.FP_CG_ATOL] = fid.cg_tol * fid.dt * GRAVITY * np.linalg.norm(mass)
        fp[itg.FP_CG_FAIL] = max(1.0, 0.1 / fid.cg_tol)
        fp[itg.FP_MAX_SPEED] = max_speed
        fp[itg.FP_MAX_DEPTH] = max_depth
        ip = np.zeros(itg.N_IP, dtype=np.int64)
        ip[itg.IP_CG_MAX_ITER] = fid.cg_max_iter
        ip[itg.IP_JACOBIAN_EVERY] = fid.effective_jacobian_every
        ip[itg.IP_POLAR_ITERS] = fid.polar_iters
        ip[itg.IP_HAS_GROUND] = self.terrain is not None
        ip[itg.IP_PRECONDITIONER] = PRECONDITIONER_CODES[fid.preconditioner]
        ip[itg.IP_FACTOR_EVERY] = fid.factor_every
        ip[itg.IP_REFACTOR_ITERS] = fid.refactor_iters
        ip[itg.IP_FACTOR_ROTATION_EVERY] = fid.factor_rotation_every if len(self._model.cluster_nodes) else 0
        self.elastic_ratio = None if fid.elastic_integration != 'auto' else elastic_stiffness_ratio(
            self._model, self.pattern, self.rest_positions, self.desired_lengths_rest, fid.dt, alpha, beta)
        self.elastic_implicit = (fid.elastic_integration == 'implicit' if self.elastic_ratio is None
                                 else not self.elastic_ratio <= EXPLICIT_ELASTIC_LIMIT)
        ip[itg.IP_ELASTIC_IMPLICIT] = self.elastic_implicit
        rates = (ElasticRates(1, np.zeros(len(self._model.tets), bool), np.inf)
                 if self.elastic_implicit or self.elastic_ratio is None else
                 elastic_rates(self._model, self.pattern, self.rest_positions, self.desired_lengths_rest, fid.dt,
                               alpha, beta, self.elastic_ratio))
        self._fast_tets_first(rates.fast)
        self.elastic_every = rates.every
        ip[itg.IP_ELASTIC_EVERY] = self.elastic_every
        ip[itg.IP_FAST_TETS] = self.elastic_fast_tets
        ip[itg.IP_MATRIX_FREE] = (not self.elastic_implicit and fid.solver == 'cg' and fid.preconditioner == 'cholesky'
                                  and self.pattern.n_blocks == len(self.rest_positions) + len(self._model.springs))
        self._fp, self._ip = fp, ip

    def _fast_tets_first(self, fast: np.ndarray) -> None:
        """Reorder the kernel model's tets so the fast ones (`fast (n_tets,)` bool) come first; count them."""
        self.elastic_fast_tets = int(fast.sum())
        if self.elastic_fast_tets == 0:
            return                                   # the mesh's order: the same sums as without a split
        order = np.concatenate([np.flatnonzero(fast), np.flatnonzero(~fast)])
        m = self._model
        self._model = m._replace(**{name: kernel_constant(getattr(m, name)[order], getattr(m, name).dtype)
                                    for name in ('tets', 'shape_gradients', 'volume', 'mu', 'lam', 'tet_blocks')})

    def _build_state(self) -> None:
        """Preallocated state and work arrays (`self._state`, a KernelState)."""
        n = len(self.rest_positions)
        self._state = empty_state(n, len(self._model.tets), self.pattern.n_blocks, len(self._model.springs))
        self._chol = self._build_factor()
        self._counters = np.zeros(itg.N_COUNTERS, dtype=np.int64)
        self._info = np.zeros(2)
        self._zero_external = np.zeros((n, 3))
        self._lengths_work = np.zeros(len(self.desired_lengths_rest))
        self._held_lengths = self.desired_lengths_rest

    def _build_factor(self) -> CholeskyFactor:
        """
        Return the CholeskyFactor of the compiled step loop (and set up its factor thread, `Fidelity.factor_thread`).

        Pattern and factor storage when the preconditioner is 'cholesky', else empty arrays of the same types.
        """
        self._factor_thread = None
        self.refactor_budget = None
        self._fp[itg.FP_REFACTOR_BUDGET] = np.inf
        if self.fidelity.preconditioner != 'cholesky':
            return empty_factor(len(self.rest_positions))
        pattern = CholeskyPattern.build(self.pattern.row_ptr, self.pattern.cols)
        threaded = self.fidelity.solver == 'cg' and self.fidelity.factor_thread == 'on'
        self._ip[itg.IP_FACTOR_THREAD] = threaded
        self._ip[itg.IP_FACTOR_LAG] = factor_lag(self.fidelity.factor_every)
        if threaded:
            self._factor_thread = FactorThread(pattern)
        self.refactor_budget = self._refactor_budget(pattern)
        self._fp[itg.FP_REFACTOR_BUDGET] = np.inf if self.refactor_budget is None else self.refactor_budget
        return pattern.factor(threaded, len(self._model.cluster_ptr) - 1)

    def _refactor_budget(self, pattern: CholeskyPattern) -> float | None:
        """Return the CG iterations beyond one per solve after which the 'amortised' rule refactorises (else None)."""
        if self.fidelity.refactor_rule != 'amortised':
            return None
        matrix_free = bool(self._ip[itg.IP_MATRIX_FREE])
        return pattern.refactor_budget(self.pattern.n_blocks if matrix_free else 0,
                                       len(self._model.springs) if matrix_free else self.pattern.n_blocks)

    def close(self) -> None:
        """Stop the factor thread, if any (it also stops when the simulator is collected)."""
        if self._factor_thread is not None:
            self._factor_thread.close()

    # ---------------------------------------------------------------------------------------------- state
    def reset(self, positions=None, velocities=None) -> None:
        """Set positions/velocities `(n_nodes, 3)` (default: rest pose at rest); clears contacts and time."""
        s = self._state
        s.positions[:] = self.rest_positions if positions is None else self._checked(positions, 'positions')
        s.velocities[:] = 0.0 if velocities is None else self._checked(velocities, 'velocities')
        s.delta_v[:] = 0.0
        s.friction_anchors[:] = 0.0
        s.contact_state[:] = CONTACT_NONE
        s.contact_stiffness[:] = 0.0                 # a node out of contact keeps zero blocks (contact_forces)
        s.contact_damping[:] = 0.0
        s.element_rotations[:] = (0.0, 0.0, 0.0, 1.0)
        if self._factor_thread is not None:
            self._factor_thread.cancel(self._chol)
        self._counters[:] = 0
        self._chol.state[:] = 0
        self._fallback_steps = 0
        self._held_lengths = self.desired_lengths_rest      # the first frame ramps from rest, never jumps
        self.time = 0.0
        self._diverged = None
        self.revision += 1
        m = self._model
        corotated_elastic_forces(s.positions, m.tets, m.shape_gradients, m.volume, m.mu, m.lam, s.element_rotations,
                                 200, np.zeros_like(s.positions), s.matrix_blocks, m.tet_blocks,
                                 0.0)                                  # converge the element rotations

    def _checked(self, array, name: str) -> np.ndarray:
        """`array` as a private copy of finite `(n_nodes, 3)` floats, or InputError."""
        a = kernel_input(array)
        if a.shape != self.rest_positions.shape or not np.all(np.isfinite(a)):
            raise InputError(f'simulator: {name} must be finite ({len(self.rest_positions)}, 3), got {a.shape}')
        return a

    @property
    def positions(self) -> np.ndarray:
        """Node positions `(n_nodes, 3)` m (a copy)."""
        return self._state.positions.copy()

    @property
    def velocities(self) -> np.ndarray:
        """Node velocities `(n_nodes, 3)` m/s (a copy)."""
        return self._state.velocities.copy()

    @property
    def in_contact(self) -> np.ndarray:
        """Per-node ground-contact flags `(n_nodes,)` bool, as of the last step."""
        return self._state.contact_state != CONTACT_NONE

    def ground_forces(self) -> np.ndarray:
        """
        Ground reaction (normal + friction) on each node `(n_nodes, 3)` N at the current state (zero without terrain).

        Evaluates the contact kernel on copies, so the simulation is not changed.
        """
        s = self._state
        forces = np.zeros_like(s.positions)
        if self.terrain is None:
            return forces
        m, fp = self._model, self._fp
        n = len(forces)
        grid = m.terrain_grid
        contact_forces(s.positions, s.velocities, m.contact_mass, m.contact_offset, m.friction, m.heights,
                       m.height_bounds, grid[0], grid[1], grid[2], fp[itg.FP_KN], fp[itg.FP_CN], fp[itg.FP_KT],
                       fp[itg.FP_CT], s.friction_anchors.copy(), s.contact_state.copy(), forces,
                       np.zeros((n, 3, 3)), np.zeros((n, 3, 3)))   # zero blocks, as every node out of contact has
        return forces

    @property
    def steps_per_frame(self) -> int:
        """Return steps in one 1/30 s reference frame at this time step."""
        return max(1, int(round(1.0 / (FRAME_RATE * self.fidelity.dt))))

    @property
    def stats(self) -> dict:
        """
        Return the counters of the run so far.

        Steps, CG iterations (total and per step), Jacobian refreshes, Cholesky factorisations, nodes in contact.
        """
        c = self._counters
        steps = int(c[itg.C_STEP])
        return {'steps': steps, 'cg_iterations': int(c[itg.C_CG_ITERS]),
                'cg_iterations_per_step': float(c[itg.C_CG_ITERS]) / max(steps, 1),
                'jacobian_refreshes': int(c[itg.C_REFRESHES]), 'nodes_in_contact': int(c[itg.C_CONTACTS]),
                'direct_fallback_steps': self._fallback_steps,
                'elastic_integration': 'implicit' if self.elastic_implicit else 'explicit',
                'elastic_every': self.elastic_every, 'elastic_fast_tets': self.elastic_fast_tets,
                'factor_thread': bool(self._ip[itg.IP_FACTOR_THREAD]),
                'factor_rotation_every': int(self._ip[itg.IP_FACTOR_ROTATION_EVERY]),
                'refactor_budget': self.refactor_budget,
                'cholesky_failures': int(c[itg.C_FACTOR_FAILS]), 'factorisations': int(c[itg.C_FACTORS])}

    # -------------------------------------------------------------------------------------------- stepping
    def advance_frame(self, desired_lengths=None, external_forces=None, n_steps: int | None = None) -> None:
        """
        Advance `n_steps` (default one 1/30 s frame) with spring desired lengths `(n_springs,)` m.

        The lengths are reached at the last step (see `length_hold`); the external forces `(n_nodes, 3)` N are constant
        (None = none). Raises SimulationDiverged on failure.
        """
        if self._diverged is not None:
            raise self._diverged
        self.revision += 1
        ld = self.desired_lengths_rest if desired_lengths is None else kernel_input(desired_lengths)
        if ld.shape != self.desired_lengths_rest.shape or not np.all(np.isfinite(ld)) or np.any(ld < 0):
            raise InputError(f'simulator: desired_lengths must be ({len(self.desired_lengths_rest)},) finite '
                             f'lengths >= 0 m, got shape {ld.shape}')
        ext = self._zero_external if external_forces is None else self._checked(external_forces, 'external_forces')
        n_steps = self.steps_per_frame if n_steps is None else int(n_steps)
        ld_from = ld if self.length_hold == 'zero' else self._held_lengths
        ramp = n_steps if ld_from is not ld else 0
        if self._direct is None:
            status, done = self._run_cg(ld_from, ld, ext, n_steps, ramp)
        else:
            status, done = self._run_direct(ld_from, ld, ext, n_steps, ramp)
        self._held_lengths = np.array(ld, dtype=np.float64)
        self.time = self._counters[itg.C_STEP] * self.fidelity.dt
        if status != itg.STATUS_OK:
            self._diverged = self._divergence(status)
            raise self._diverged

    @property
    def held_lengths(self) -> np.ndarray:
        """Return the desired spring lengths `(n_springs,)` m reached at the end of the last advance."""
        return self._held_lengths

    def load_kernels(self) -> None:
        """Call the compiled step loop for zero steps: numba loads its code now, not in the first frame."""
        if self._direct is None:
            itg.run_steps_cg(self._model, self._state, self._fp, self._ip, self._counters, self.desired_lengths_rest,
                             self.desired_lengths_rest, self._lengths_work, self._zero_external, 0, self._info,
                             self._chol, 0, 0)

    def advance(self, duration: float, desired_lengths=None, external_forces=None) -> None:
        """Advance by `duration` s (rounded to whole steps) with fixed inputs."""
        self.advance_frame(desired_lengths, external_forces, int(round(duration / self.fidelity.dt)))

    def _run_cg(self, ld_from, ld, ext, n_steps, ramp) -> tuple:
        """Return steps in one compiled call; a step whose CG fails is solved by sparse LU (if `cg_fallback`)."""
        done_total = 0
        while True:
            status, done = itg.run_steps_cg(self._model, self._state, self._fp, self._ip, self._counters,
                                            ld_from, ld, self._lengths_work, ext, n_steps - done_total, self._info,
                                            self._chol, done_total, ramp)
            done_total += done
            if status in (itg.STATUS_FACTOR_REQUEST, itg.STATUS_FACTOR_SWAP):
                if status == itg.STATUS_FACTOR_REQUEST:
                    self._factor_thread.start(self._chol)
                else:
                    self._chol = self._factor_thread.swap(self._chol, self._counters)
                if done_total >= n_steps:
                    return itg.STATUS_OK, done_total
                continue
            if status != itg.STATUS_SOLVER or self._fallback is None:
                return status, done_total
            if self._ip[itg.IP_MATRIX_FREE]:
                itg.assemble_system_matrix(self._model, self._state)
            try:                                     # the failed step is prepared: matrix and rhs are current
                self._fallback.factorize(self._state.matrix_blocks)
            except RuntimeError:
                return itg.STATUS_SOLVER, done_total
            self._fallback.solve(self._state.rhs, self._state.delta_v)
            self._fallback_steps += 1
            status = itg.finish_step(self._state, self._fp, self._counters, self._info)
            done_total += 1
            if status != itg.STATUS_OK or done_total >= n_steps:
                return status, done_total

    def _run_direct(self, ld_from, ld_to, ext, n_steps, ramp) -> tuple:
        """Step loop around scipy's sparse LU (refactorised when the Jacobian is refreshed)."""
        state = self._state
        ld = ld_to
        for step in range(n_steps):
            if ramp:
                itg.ramp_lengths(ld_from, ld_to, self._lengths_work, min(1.0, (step + 1) / ramp))
                ld = self._lengths_work
            status, refreshed = itg.prepare_step(self._model, state, self._fp, self._ip, self._counters, ld, ext,
                                                 self._info)
            if status != itg.STATUS_OK:
                return status, step
            if refreshed:
                try:
                    self._direct.factorize(state.matrix_blocks)
                except RuntimeError:
                    self._info[:] = (-1, np.inf)
                    return itg.STATUS_SOLVER, step
            self._direct.solve(state.rhs, state.delta_v)
            status = itg.finish_step(state, self._fp, self._counters, self._info)
            if status != itg.STATUS_OK:
                return status, step + 1
        return itg.STATUS_OK, n_steps

    def _divergence(self, status: int) -> SimulationDiverged:
        """Return the error for a failed step, naming the cause, the time and what to change."""
        node, value = int(self._info[0]), float(self._info[1])
        t = self._counters[itg.C_STEP] * self.fidelity.dt
        hint = 'reduce dt, stiffness or forces, or use a more accurate fidelity preset'
        messages = {
            itg.STATUS_NAN: f'node {node} position or velocity became NaN/Inf',
            itg.STATUS_SPEED: f'node {node} reached {value:.3g} m/s, above the {self._fp[itg.FP_MAX_SPEED]:g} m/s '
                              'bound',
            itg.STATUS_PENETRATION: f'node {node} is {value:.3g} m inside the terrain (bound '
                                    f'{self._fp[itg.FP_MAX_DEPTH]:g} m)',
            itg.STATUS_SOLVER: f'the CG linear solver failed (code {node}, residual {value:.3g}× its threshold); '
                               'raise cg_max_iter or use solver="direct"',
        }
        return SimulationDiverged(_CAUSES[status], f'simulation diverged at t={t:.4f} s: {messages[status]}; {hint}',
                                  time=t, node=node)

    # ------------------------------------------------------------------------------------------- summaries
    def center_of_mass(self) -> np.ndarray:
        """Mass-weighted mean node position `(3,)` m."""
        mass = self._model.mass
        return mass @ self._state.positions / mass.sum()

    def root_pose(self) -> tuple:
        """Best rigid fit of the rest shape to the current nodes: (COM position (3,), quaternion xyzw (4,))."""
        mass = self._model.mass
        x = self._state.positions
        rot, _ = rigid_fit(self.rest_positions, x, mass)
        return mass @ x / mass.sum(), matrix_to_quat(rot)
