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
Stiffness presets of the soft body: spring scale `a`, leg factor, Young's modulus, Poisson ratio.

`normal` is the moderate model used in every experiment of the paper and `softer` the Section VIII-D
model with softer springs that absorb a push better. Springs follow f_s = a (l_d - l) per spring; `a` is
normalised by rest length (a = A * L_REF / l_rest) so every spring resists the same *strain* with the same
force: a 1 % stretch of any trunk spring pulls with A * L_REF * 0.01 N (normal: 300 kN/m * 0.02 m * 0.01
= 60 N). Springs between two leg nodes are LEG_FACTOR times stiffer ("high-tension springs", Section V) so
legs barely change length; springs from a leg node to a trunk node get the geometric mean (sqrt(LEG_FACTOR)).

The springs are the actuators (they pull toward the *reference* shape), the corotated FEM pulls toward the
*rest* shape; the presets are spring-dominated (FEM only keeps elements from degenerating), because a stiff
FEM resists every joint bend the springs command (measured on the coarse body, suspended without gravity:
with A = 300 N/m and E = 50 kPa the swing feet reach ~45 % of their reference lift, with A = 3 kN/m and
E = 10 kPa 90-110 %). The spring scale is set by the trot, not by standing: at A = 300 N/m the 4 kg body
lay on its belly, at 30 kN/m it stood (pelvis sag ~7 mm) but could not lift its hind feet, at 300 kN/m it
trots (docs/RESULTS.md, "Locomotion").
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from iguana_ros.errors import InputError

L_REF = 0.02
"""Reference spring length of the stiffness normalisation, m."""


@dataclass(frozen=True)
class StiffnessPreset:
    """Spring scale `a` at L_REF (N/m), leg multiplier, Young's modulus (Pa), leg E multiplier, Poisson."""

    spring_a: float
    leg_factor: float
    youngs_modulus: float
    leg_youngs_factor: float
    poisson_ratio: float


PRESETS = {
    # moderate springs (paper: "normal model"): 300 kN/m at L_REF, legs x3 (leg-leg springs 900 kN/m), weak FEM
    # (10 kPa, about soft fat tissue) that only keeps elements from degenerating. Set by what a trot needs
    # (docs/RESULTS.md, "Why the hind feet did not lift"): at 30 kN/m (legs x10) the loaded trunk sagged ~15 mm onto
    # each swinging hind foot (its commanded lift over the hip is 11-15 mm) and the hind feet never lifted; x3
    # left them 1-3 mm clear; x10 lifts every swing >= 1 cm. Legs only 3x the trunk (not 10x): stiffer legs
    # turn millimetre misfits between the planted feet into friction-limit forces (slip +40 %).
    'normal': StiffnessPreset(spring_a=3.0e5, leg_factor=3.0, youngs_modulus=1.0e4,
                              leg_youngs_factor=1.0, poisson_ratio=0.35),
    # Section VIII-D "softer model": every spring 2/3x, FEM 0.5x (feet softer too, larger contact patches)
    'softer': StiffnessPreset(spring_a=2.0e5, leg_factor=3.0, youngs_modulus=5.0e3,
                              leg_youngs_factor=1.0, poisson_ratio=0.35),
}
"""Named stiffness presets."""


def stiffness_preset(name: str) -> StiffnessPreset:
    """Return the preset called `name`; InputError lists the choices."""
    if name not in PRESETS:
        raise InputError(f'unknown stiffness preset {name!r}; expected one of: {", ".join(PRESETS)}')
    return PRESETS[name]


def spring_stiffness(preset: StiffnessPreset, rest_lengths: np.ndarray, springs: np.ndarray,
                     leg_nodes: np.ndarray) -> np.ndarray:
    """Spring scales `a (n_springs,)` N/m from rest lengths `(n_springs,)` and a leg-node mask `(n_nodes,)`."""
    node_factor = np.where(leg_nodes, preset.leg_factor, 1.0)
    factor = np.sqrt(node_factor[springs[:, 0]] * node_factor[springs[:, 1]])
    return preset.spring_a * (L_REF / rest_lengths) * factor


def youngs_moduli(preset: StiffnessPreset, tets: np.ndarray, leg_nodes: np.ndarray) -> np.ndarray:
    """Young's modulus `(n_tets,)` Pa: legs (tets with >= 3 leg nodes) stiffer by leg_youngs_factor."""
    legs = leg_nodes[tets].sum(axis=1) >= 3
    return np.where(legs, preset.youngs_modulus * preset.leg_youngs_factor, preset.youngs_modulus)
