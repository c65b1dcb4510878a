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

"""The explicit FEM's tets split into held and fast ones (`physics.elastic_rates`): bound kept, less work, same walk."""
import numpy as np
import pytest

from iguana_lab.bench.workload import gait_for
from iguana_ros.body.model import build_model
from iguana_ros.constants import RAYLEIGH_ALPHA, RAYLEIGH_BETA
from iguana_ros.physics import integrator as itg
from iguana_ros.physics.elastic_rates import (elastic_stiffness_matrix, HELD_ELASTIC_LIMIT, largest_ratio,
                                              rest_system_matrix)
from iguana_ros.physics.fidelity import MAX_ELASTIC_EVERY
from iguana_ros.physics.simulator import SoftBodySimulator
from iguana_ros.terrain.heightfield import HeightField


@pytest.fixture(scope='module')
def coarse():
    return build_model('coarse', 'normal')


def _held_ratio(sim) -> float:
    """Return h² λ_max of the held tets (all but the first `elastic_fast_tets`) of `sim`'s body at rest."""
    m, h = sim._model, sim.fidelity.dt
    a = rest_system_matrix(m, sim.pattern, sim.rest_positions, sim.desired_lengths_rest, h, RAYLEIGH_ALPHA,
                           RAYLEIGH_BETA)
    return largest_ratio(elastic_stiffness_matrix(m, sim.pattern, sim.rest_positions,
                                                  np.arange(sim.elastic_fast_tets, len(m.tets))), a, h)[0]


@pytest.mark.parametrize('resolution', ['medium', 'fine'])
def test_medium_and_fine_hold_their_tets_longer_for_a_few_fast_ones(resolution):
    """Medium and fine: a few tets every step let the others be held longer than all could be, within the bound."""
    sim = SoftBodySimulator(build_model(resolution, 'normal'), None, 'balanced')
    n_tets, n_fast, every = len(sim.model.tets), sim.elastic_fast_tets, sim.elastic_every
    unsplit = int(np.floor(np.sqrt(HELD_ELASTIC_LIMIT / sim.elastic_ratio)))
    assert 0 < n_fast < 0.05 * n_tets and unsplit < every <= MAX_ELASTIC_EVERY
    assert every * every * _held_ratio(sim) <= HELD_ELASTIC_LIMIT * 1.001
    assert n_fast + (n_tets - n_fast) / every < n_tets / unsplit


def test_the_held_tets_keep_the_held_bound_and_the_stiff_mode_is_fast(coarse):
    """Coarse: a few tets every step, the rest held k steps with (k h)² λ of the held ones within the limit."""
    sim = SoftBodySimulator(coarse, None, 'balanced')
    m, n_fast, every = sim._model, sim.elastic_fast_tets, sim.elastic_every
    assert sim._ip[itg.IP_FAST_TETS] == n_fast and sim._ip[itg.IP_ELASTIC_EVERY] == every
    h = sim.fidelity.dt
    a = rest_system_matrix(m, sim.pattern, sim.rest_positions, sim.desired_lengths_rest, h, RAYLEIGH_ALPHA,
                           RAYLEIGH_BETA)
    held, _ = largest_ratio(elastic_stiffness_matrix(m, sim.pattern, sim.rest_positions,
                                                     np.arange(n_fast, len(m.tets))), a, h)
    assert every * every * held <= HELD_ELASTIC_LIMIT * 1.001
    assert every * every * sim.elastic_ratio > 100 * HELD_ELASTIC_LIMIT        # unsplit it would be every step
    evaluations = n_fast + (len(m.tets) - n_fast) / every
    assert evaluations < 0.5 * len(m.tets)
    _, mode = largest_ratio(elastic_stiffness_matrix(m, sim.pattern, sim.rest_positions, np.arange(len(m.tets))), a, h)
    stiffest_node = int(np.argmax(np.linalg.norm(mode, axis=1)))                # the tail tip's sideways mode
    assert np.any(m.tets[:n_fast] == stiffest_node) and not np.any(m.tets[n_fast:] == stiffest_node)


def test_stopping_the_rounds_early_keeps_the_split(monkeypatch):
    """Medium: the rounds stop once the fast tets alone cost the best split; every round run gives the same split."""
    from iguana_ros.physics import elastic_rates as rates

    sim = SoftBodySimulator(build_model('medium'), None, 'balanced')
    args = (sim._model, sim.pattern, sim.rest_positions, sim.desired_lengths_rest, sim.fidelity.dt, RAYLEIGH_ALPHA,
            RAYLEIGH_BETA, sim.elastic_ratio)
    rounds = []
    solve = rates.largest_ratio
    monkeypatch.setattr(rates, 'largest_ratio', lambda *a, **k: rounds.append(1) or solve(*a, **k))
    early = rates.elastic_rates(*args)
    n_early = len(rounds)
    monkeypatch.setattr(rates, '_fewest_evaluations', lambda fast: 0.0)
    every_round = rates.elastic_rates(*args)
    assert n_early < len(rounds) - n_early                   # fewer eigensolves ...
    assert early.every == every_round.every and np.array_equal(early.fast, every_round.fast)   # ... the same split


def test_a_body_whose_every_tet_takes_the_longest_hold_is_not_split():
    """Medium at dt 1/4800 (every tet within the bound at MAX_ELASTIC_EVERY): none fast, the mesh order kept."""
    sim = SoftBodySimulator(build_model('medium'), None, 'balanced', dt=1.0 / 4800.0)
    assert MAX_ELASTIC_EVERY ** 2 * sim.elastic_ratio <= HELD_ELASTIC_LIMIT
    assert sim.elastic_every == MAX_ELASTIC_EVERY and sim.elastic_fast_tets == 0 == sim._ip[itg.IP_FAST_TETS]


def test_the_split_walks_like_the_implicit_step(coarse):
    """0.5 s of the bench gait on hills: the split within 1 mm RMS of the implicit FEM (dt 1/1200 errs by ~17 mm)."""
    terrain = HeightField.hills(amplitude=0.03, wavelength=0.6, seed=0, extent=3.0)
    gait = gait_for(coarse)
    runs = {}
    for scheme in ('implicit', 'auto'):
        sim = SoftBodySimulator(coarse, terrain, 'balanced', elastic_integration=scheme)
        start = sim.rest_positions + [0.0, 0.0, 0.05]
        sim.reset(start)
        for _ in range(15):
            sim.advance_frame(gait.desired_lengths(sim.time))
        runs[scheme] = sim.positions
    assert sim.elastic_fast_tets > 0
    moved = np.sqrt(np.mean(np.sum((runs['implicit'] - start) ** 2, axis=1)))
    gap = np.sqrt(np.mean(np.sum((runs['auto'] - runs['implicit']) ** 2, axis=1)))
    assert moved > 0.05 and gap < 1e-3
