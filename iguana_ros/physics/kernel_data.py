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
The named structs the compiled (numba) step kernels take: the body's static arrays and its state.

numba passes a NamedTuple as a plain struct, so naming the fields costs nothing at run time (cf. MuJoCo's
`MjModel` / `MjData`); the kernels read `model.mass`, `state.positions` where they read positions in a tuple
before. Shapes: n nodes, n_tets tetrahedra, n_springs springs, n_blocks stored 3x3 blocks of the system matrix
(its upper block triangle, `iguana_ros.physics.assembly`).
"""
from __future__ import annotations

from typing import NamedTuple

import numpy as np


def kernel_constant(array, dtype=np.float64) -> np.ndarray:
    """
    Return a private, read-only, C-contiguous copy of `array` as `dtype`: how every KernelModel field is passed.

    numba compiles one specialisation per combination of array flags, and a specialisation compiled in a process
    that loaded the others from the cache rounds differently (1e-16 m within a second, then chaotic): two processes
    of one run stepped differently. One array type per argument keeps every process on the kernels `iguana warm`
    compiled together (`test/test_warmup.py`).
    """
    out = np.array(array, dtype=dtype, order='C', copy=True)
    out.setflags(write=False)
    return out


def kernel_input(array, dtype=np.float64) -> np.ndarray:
    """Return a private, writable, C-contiguous copy of `array` as `dtype`: how per-call kernel inputs are passed."""
    return np.array(array, dtype=dtype, order='C', copy=True)


class KernelModel(NamedTuple):
    """Static arrays of one soft body on one terrain (set up once by `SoftBodySimulator`)."""

    mass: np.ndarray              # (n,) kg
    tets: np.ndarray              # (n_tets, 4) int64, nodes in ascending order
    shape_gradients: np.ndarray   # (n_tets, 4, 3) 1/m, moved with the nodes
    volume: np.ndarray            # (n_tets,) m³, rest volumes
    mu: np.ndarray                # (n_tets,) Pa, first Lamé parameter
    lam: np.ndarray               # (n_tets,) Pa, second Lamé parameter
    springs: np.ndarray           # (n_springs, 2) int64, node pairs
    spring_stiffness: np.ndarray  # (n_springs,) N/m
    friction: np.ndarray          # (n,) Coulomb μ per node
    heights: np.ndarray           # (nx, ny) m, the height field's grid (a 2 x 2 dummy without terrain)
    height_bounds: np.ndarray     # (ceil((nx - 1) / 4), ...) m, highest height of each block (heightfield.block_maxima)
    terrain_grid: np.ndarray      # (3,) grid origin x, origin y and spacing, m
    row_ptr: np.ndarray           # (n + 1,) int64, block-CSR rows of the system matrix
    cols: np.ndarray              # (n_blocks,) int64, block columns
    diag: np.ndarray              # (n,) int64, index of each diagonal block A_ii
    tet_blocks: np.ndarray        # (n_tets, 16) int64, stored block of node pair (a, b) of a tet at 4 a + b
    spring_blocks: np.ndarray     # (n_springs, 3) int64, blocks (i, i), (j, j) and the stored (i, j)
    node_spring_ptr: np.ndarray   # (n + 1,) int64, CSR rows of the springs at each node ...
    node_springs: np.ndarray      # (2 n_springs,) int64, ... ascending (forces.assemble_spring_matrix)
    contact_mass: np.ndarray      # (n,) kg, node mass for the contact damping (light nodes get the mean)
    contact_offset: np.ndarray    # (n,) m, contact offset below each node (sole pads)
    cluster_ptr: np.ndarray       # (n_clusters + 1,) int64, CSR rows of the node clusters of one rotation ...
    cluster_nodes: np.ndarray     # (n,) int64, ... (physics.factor_rotation, the corotated preconditioner)


class KernelState(NamedTuple):
    """The body's state and the work arrays of a step (preallocated once, written in place)."""

    positions: np.ndarray          # (n, 3) m
    velocities: np.ndarray         # (n, 3) m/s
    delta_v: np.ndarray            # (n, 3) m/s, the step's velocity change (the linear solve's unknown)
    element_rotations: np.ndarray  # (n_tets, 4) xyzw, warm-started corotation of each tet
    friction_anchors: np.ndarray   # (n, 3) m, where each sticking contact is anchored
    contact_state: np.ndarray      # (n,) int64, CONTACT_NONE / _STICK / _SLIP (physics.forces)
    matrix_blocks: np.ndarray      # (n_blocks, 3, 3), the system matrix A
    diag_mass_damping: np.ndarray  # (n, 3, 3), M(1 + hα) + h C_c: the part of A_ii that is not stiffness
    diag_inv: np.ndarray           # (n, 3, 3), A_ii⁻¹ for the block Jacobi preconditioner
    forces: np.ndarray             # (n, 3) N
    elastic_forces: np.ndarray     # (n, 3) N, the FEM force of an explicit step, held for `elastic_every` steps
    spring_coef: np.ndarray        # (5, n_springs), each spring's scaled stiffness K_s = c u uᵀ + g I as (u, c, g)
    spring_work: np.ndarray        # (9, n_springs), the matrix-free springs' pass: end differences, then its terms
    node_work: np.ndarray          # (n, 9), x, v and Δv of each node in one row (the springs' pass gathers rows)
    node_matrix: np.ndarray        # (n, 3, 3), M(1 + hα) + h C_c + h² K_c: A_ii without the springs (matrix-free)
    rhs: np.ndarray                # (n, 3), right-hand side of A Δv = b
    cg_work: np.ndarray            # (4, n, 3), CG vectors r, z, p, Ap
    contact_stiffness: np.ndarray  # (n, 3, 3) N/m, K_c per node
    contact_damping: np.ndarray    # (n, 3, 3) N s/m, C_c per node
    contact_in_matrix: np.ndarray  # (n, 3, 3), h C_c + h² K_c as currently added to A_ii


def empty_state(n_nodes: int, n_tets: int, n_blocks: int, n_springs: int) -> KernelState:
    """Zeroed KernelState for `n_nodes` nodes, `n_tets` tets, `n_blocks` matrix blocks and `n_springs` springs."""
    n = n_nodes
    return KernelState(
        positions=np.zeros((n, 3)), velocities=np.zeros((n, 3)), delta_v=np.zeros((n, 3)),
        element_rotations=np.zeros((n_tets, 4)), friction_anchors=np.zeros((n, 3)),
        contact_state=np.zeros(n, dtype=np.int64), matrix_blocks=np.zeros((n_blocks, 3, 3)),
        diag_mass_damping=np.zeros((n, 3, 3)), diag_inv=np.zeros((n, 3, 3)), forces=np.zeros((n, 3)),
        elastic_forces=np.zeros((n, 3)), spring_coef=np.zeros((5, n_springs)),
        spring_work=np.zeros((9, n_springs)), node_work=np.zeros((n, 9)), node_matrix=np.zeros((n, 3, 3)),
        rhs=np.zeros((n, 3)), cg_work=np.zeros((4, n, 3)), contact_stiffness=np.zeros((n, 3, 3)),
        contact_damping=np.zeros((n, 3, 3)), contact_in_matrix=np.zeros((n, 3, 3)))


class SpringOperator(NamedTuple):
    """
    The system matrix of a matrix-free step, A = blockdiag(node_matrix) + Σ_s K_s (`forces.spring_operator_matvec`).

    `active` 0: the CG multiplies by the stored blocks instead (then the arrays may be empty).
    """

    springs: np.ndarray      # (n_springs, 2) int64
    coef: np.ndarray         # (5, n_springs), KernelState.spring_coef
    node_matrix: np.ndarray  # (n, 3, 3), KernelState.node_matrix
    active: int
