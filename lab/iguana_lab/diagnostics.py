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
Why a soft body does or does not trot, measured: support margins, standing sag, spring capacity, planted feet.

Four measurements of a model variant (ROS-free; `iguana bench statics` prints them):

* `support_margins`: in every two-foot (diagonal) phase of a clip, how far the reference centre of mass lies
  outside the line between the two stance feet (toward the swinging hind foot), whether the tail's lowest
  point closes a support triangle around it, and the tail load that triangle needs.
* `static_sag`: the body standing in a held pose for a while (the idle clip's first pose on four feet, or a
  two-foot frame of the trot); how far each region hangs below the reference mesh of that pose, and how the
  ground load splits between feet and tail.
* `spring_capacity`: per vertical plane, the bending moment the springs crossing it exert at 1 % strain next
  to the gravity moment of the body part beyond it (the strain the springs need to hold that part up).
* `planted_feet`: the pipeline walking a scene; per foot in its stance frames, how many sole nodes touch, how
  much its normal force rings, how often it sits at the friction limit; the load on a swinging hind foot.

Foot order everywhere: fl, fr, hl, hr. Every length is in m, force in N, moment in N m.
"""
from __future__ import annotations

import dataclasses
import time

import numpy as np

from iguana_ros.body.mesh import PART_LIMB0
from iguana_ros.body.model import IguanaModel
from iguana_ros.body.skeleton import FEET, rest_joint_positions
from iguana_ros.body.spring_lengths import SpringLengthComputer
from iguana_ros.body.stiffness import spring_stiffness, stiffness_preset
from iguana_ros.constants import FRAME_RATE, GRAVITY
from iguana_ros.errors import InputError
from iguana_ros.motion.clips import Clip, load_clip_library
from iguana_ros.physics.simulator import SoftBodySimulator
from iguana_ros.pipeline import build_pipeline, Pipeline
from iguana_ros.run_metrics import bone_node_groups, TRUNK
from iguana_ros.scene import load_scene, ModelSpec, Scene
from iguana_ros.stages import simulator_stage, spring_stage
from iguana_ros.terrain.heightfield import HeightField
from iguana_ros.terrain.placement import place_on_terrain

DIAGONALS = {(True, False, False, True): ('fl+hr', 2), (False, True, True, False): ('fr+hl', 3)}
"""Clip stance flags of a diagonal (two-foot) phase -> (name, index of the swinging hind foot)."""
TRUNK_REGIONS = dict(zip(('pelvis', 'mid_trunk', 'shoulders'), TRUNK))
"""Trunk regions of `static_sag` -> the bone their nodes are dominantly skinned to."""
TAIL_THIRDS = ('tail_base', 'tail_middle', 'tail_tip')
"""The tail's nodes split into thirds of its rest length, base first."""
CAPACITY_PLANES = {'pelvis': 'pelvis', 'mid_trunk': 'spine_3', 'tail_base': 'tail_1'}
"""Default planes of `spring_capacity`: name -> the bone whose rest joint x the plane passes through."""
CAPACITY_STRAIN = 0.01
"""Spring strain at which `spring_capacity` evaluates the springs' bending moment (1 %)."""
FRICTION_LIMIT_FRACTION = 0.95
"""A foot whose summed |F_t| reaches this fraction of μ F_n counts as at the friction limit."""


# --------------------------------------------------------------------------------------------- model variant

def model_variant(model: IguanaModel, spring_scale: float = 1.0, leg_factor: float | None = None) -> IguanaModel:
    """
    Return `model` with every spring stiffness times `spring_scale` and the leg factor replaced by `leg_factor`.

    None keeps a value; the same model object is returned when nothing changes.
    """
    if not (np.isfinite(spring_scale) and spring_scale > 0):
        raise InputError(f'spring scale must be a positive number, got {spring_scale!r}')
    if leg_factor is not None and not (np.isfinite(leg_factor) and leg_factor > 0):
        raise InputError(f'leg factor must be a positive number, got {leg_factor!r}')
    if spring_scale == 1.0 and leg_factor is None:
        return model
    preset = stiffness_preset(model.stiffness)
    if leg_factor is not None:
        preset = dataclasses.replace(preset, leg_factor=float(leg_factor))
    stiffness = spring_scale * spring_stiffness(preset, model.spring_rest_lengths, model.springs,
                                                model.node_part >= PART_LIMB0)
    stiffness.setflags(write=False)
    return dataclasses.replace(model, spring_stiffness=stiffness)


def stiffness_summary(model: IguanaModel) -> dict:
    """
    Return the resolution, preset, effective spring scale A at L_REF (N/m) and leg factor of `model`.

    They are read back from its spring stiffness, so a `model_variant` reports its own values.
    """
    preset = stiffness_preset(model.stiffness)
    legs = model.node_part >= PART_LIMB0
    both = legs[model.springs[:, 0]] & legs[model.springs[:, 1]]
    neither = ~legs[model.springs[:, 0]] & ~legs[model.springs[:, 1]]
    unit = spring_stiffness(dataclasses.replace(preset, spring_a=1.0, leg_factor=1.0), model.spring_rest_lengths,
                            model.springs, legs)
    scale = np.asarray(model.spring_stiffness) / unit
    spring_a = float(np.median(scale[neither])) if neither.any() else float('nan')
    leg = float(np.median(scale[both])) / spring_a if both.any() else float('nan')
    return {'resolution': model.resolution, 'stiffness': model.stiffness, 'nodes': model.n_nodes,
            'springs': len(model.springs), 'spring_a_n_per_m': spring_a, 'leg_factor': leg,
            'mass_kg': float(np.sum(model.node_mass))}


# ------------------------------------------------------------------------------------------- support margins

def line_margin(point_xy: np.ndarray, a_xy: np.ndarray, b_xy: np.ndarray, side_xy: np.ndarray) -> dict:
    """
    Return the signed horizontal distance (m) of `point_xy (2,)` from the line through `a_xy`, `b_xy (2,)`.

    It is positive on the side of `side_xy (2,)`. The line's angle from +x (rad, in [-pi/2, pi/2]) and that unit normal
    come with it.
    """
    a, b = np.asarray(a_xy, float)[:2], np.asarray(b_xy, float)[:2]
    direction = (b - a) / np.linalg.norm(b - a)
    normal = np.array([-direction[1], direction[0]])
    if normal @ (np.asarray(side_xy, float)[:2] - a) < 0:
        normal = -normal
    angle = float(np.arctan2(direction[1], direction[0]))
    if angle > np.pi / 2:
        angle -= np.pi
    elif angle < -np.pi / 2:
        angle += np.pi
    return {'distance': float(normal @ (np.asarray(point_xy, float)[:2] - a)), 'angle': angle, 'normal': normal}


def inside_triangle(point_xy: np.ndarray, a_xy: np.ndarray, b_xy: np.ndarray, c_xy: np.ndarray) -> bool:
    """Whether `point_xy (2,)` lies inside (or on an edge of) the horizontal triangle `a_xy`, `b_xy`, `c_xy (2,)`."""
    p, a, b, c = (np.asarray(v, float)[:2] for v in (point_xy, a_xy, b_xy, c_xy))

    def cross(u: np.ndarray, v: np.ndarray) -> float:
        return float(u[0] * v[1] - u[1] * v[0])
    signs = np.array([cross(b - a, p - a), cross(c - b, p - b), cross(a - c, p - c)])
    scale = 1e-12 * max(1.0, abs(cross(b - a, c - a)))
    return bool(np.all(signs >= -scale) or np.all(signs <= scale))


def support_margins(model: IguanaModel, clip: Clip) -> dict:
    """
    Measure the centre of mass against the diagonal support lines of `clip` on `model`'s reference mesh.

    `clip` is a `motion.clips.Clip`: `root_positions (N+1, 3)`, `local_rotations (N+1, n_bones, 4)`,
    `contacts (N+1, 4)`.

    In every frame whose stance flags are exactly one diagonal pair (fl+hr or fr+hl): the signed horizontal
    distance of the mass-weighted COM from the line through the two stance feet's sole centroids, positive
    toward the swinging hind foot (there the body rolls onto that foot); whether the COM lies inside the
    triangle of the two stance feet and the tail's lowest node; and the tail load (N) that triangle needs for
    moment balance about the diagonal line, m g d / lever of the tail point (<= 0: the tail cannot help; NaN:
    the tail point lies on the line or on the stance side). Returns the per-frame rows and their summary.
    """
    computer = SpringLengthComputer(model)
    mass = np.asarray(model.node_mass, float)
    weight = float(mass.sum()) * GRAVITY
    feet = [np.flatnonzero(model.node_tags[f]) for f in FEET]
    tail = np.flatnonzero(model.node_tags['tail'])
    rows = []
    for i, flags in enumerate(np.asarray(clip.contacts, bool)):
        phase = DIAGONALS.get(tuple(bool(f) for f in flags))
        if phase is None:
            continue
        name, swing_hind = phase
        nodes = computer.skin_pose(clip.root_positions[i], clip.local_rotations[i])
        com = mass @ nodes / mass.sum()
        soles = np.array([nodes[f].mean(axis=0) for f in feet])
        a, b = soles[np.flatnonzero(flags)]
        tail_point = nodes[tail[np.argmin(nodes[tail, 2])]]
        margin = line_margin(com, a, b, soles[swing_hind])
        lever = line_margin(tail_point, a, b, soles[swing_hind])['distance']
        rows.append({'frame': i, 'stance': name, 'distance_m': margin['distance'], 'line_angle_rad': margin['angle'],
                     'com_m': com.tolist(), 'tail_point_m': tail_point.tolist(), 'tail_lever_m': lever,
                     'inside_tail_triangle': inside_triangle(com, a, b, tail_point),
                     'tail_load_n': weight * margin['distance'] / lever if lever > 0 else float('nan')})
    distances = np.array([r['distance_m'] for r in rows])
    loads = np.array([r['tail_load_n'] for r in rows])
    return {
        'clip': getattr(clip, 'name', ''), 'frames': int(len(clip.contacts)), 'diagonal_frames': len(rows),
        'weight_n': weight,
        'distance_mean_m': _stat(np.mean, distances), 'distance_min_m': _stat(np.min, distances),
        'distance_max_m': _stat(np.max, distances),
        'inside_tail_triangle_fraction': _stat(np.mean, np.array([r['inside_tail_triangle'] for r in rows], float)),
        'tail_load_median_n': _stat(np.median, loads[np.isfinite(loads)]),
        'rows': rows,
    }


def _stat(reduce, values: np.ndarray) -> float:
    """`reduce(values)` as a float, NaN for no values."""
    return float(reduce(values)) if len(values) else float('nan')


# ------------------------------------------------------------------------------------------------- static sag

def sag_regions(model: IguanaModel) -> dict:
    """
    Node indices of the `static_sag` regions.

    Pelvis, mid trunk, shoulders (dominant skin bone), head (tag), tail base / middle / tip (thirds of the tail tag's
    rest x range), each foot's sole (tag).
    """
    regions = dict(zip(TRUNK_REGIONS, bone_node_groups(model, tuple(TRUNK_REGIONS.values()))))
    regions['head'] = np.flatnonzero(model.node_tags['head'])
    tail = np.flatnonzero(model.node_tags['tail'])
    x = np.asarray(model.rest_positions)[tail, 0]
    edges = np.linspace(x.max(), x.min(), len(TAIL_THIRDS) + 1)
    third = np.clip(np.searchsorted(-edges, -x, side='right') - 1, 0, len(TAIL_THIRDS) - 1)
    regions.update({name: tail[third == k] for k, name in enumerate(TAIL_THIRDS)})
    regions.update({f: np.flatnonzero(model.node_tags[f]) for f in FEET})
    return regions


def ground_load_groups(model: IguanaModel) -> dict:
    """Node indices whose ground forces make up each foot's load (every node of its limb) and the tail's."""
    groups = {f: np.flatnonzero(np.asarray(model.node_part) == PART_LIMB0 + k) for k, f in enumerate(FEET)}
    groups['tail'] = np.flatnonzero(model.node_tags['tail'])
    return groups


def place_by_feet(positions: np.ndarray, feet: np.ndarray, terrain: HeightField) -> np.ndarray:
    """Nodes `(n_nodes, 3)` moved vertically so the lowest of the `feet` nodes (indices) stands on `terrain`."""
    gap = positions[feet, 2] - terrain.height(positions[feet, :2])
    out = np.array(positions, float)
    out[:, 2] -= float(gap.min())
    return out


def static_sag(model: IguanaModel, seconds: float = 2.0, fidelity: str = 'balanced', clip: Clip | None = None,
               frame: int = 0) -> dict:
    """
    Simulate the body standing on flat ground for `seconds`, its desired lengths held at pose `frame` of `clip`.

    `clip` is a `motion.clips.Clip`; the default is the idle clip, whose first pose stands on all four feet. A frame of
    a diagonal phase of `forward` holds the trot's two-foot support with the swing feet lifted.

    Starts from that pose's reference mesh placed on the ground (`terrain.placement.place_on_terrain`: no node below
    it). The reference the offsets are measured from is the same mesh standing on its feet (its lowest sole
    node on the ground, as on the clips' capture floor; the clips press the tail below that floor so it bears
    weight, so placing it by its lowest node would lift the feet). Per region (`sag_regions`): the mean
    vertical offset (m, negative = lower than the reference) of its nodes, averaged over the frames of the
    last quarter of the run; the ground load (N) per foot and on the tail over the same frames.
    """
    if not (np.isfinite(seconds) and seconds > 0):
        raise InputError(f'static sag: seconds must be positive, got {seconds!r}')
    clip = load_clip_library()['idle'] if clip is None else clip
    terrain = HeightField.flat()
    computer = SpringLengthComputer(model)
    if not 0 <= frame < len(clip.root_positions):
        raise InputError(f'static sag: frame {frame} is outside the clip (0..{len(clip.root_positions) - 1})')
    pose = computer.skin_pose(clip.root_positions[frame], clip.local_rotations[frame])
    lengths = computer(clip.root_positions[frame], clip.local_rotations[frame])
    reference = place_by_feet(pose, np.flatnonzero(model.node_tags['feet']), terrain)
    sim = SoftBodySimulator(model, terrain, fidelity)
    sim.reset(positions=place_on_terrain(pose, terrain, lift_only=True))
    n_frames = max(1, int(round(seconds * FRAME_RATE)))
    window = max(1, n_frames // 4)
    regions, loads = sag_regions(model), ground_load_groups(model)
    offsets, forces = [], []
    for step in range(n_frames):
        sim.advance_frame(lengths)
        if step >= n_frames - window:
            offsets.append(sim.positions[:, 2] - reference[:, 2])
            forces.append(sim.ground_forces()[:, 2])
    dz, fz = np.mean(offsets, axis=0), np.mean(forces, axis=0)
    load = {name: float(fz[idx].sum()) for name, idx in loads.items()}
    load['total'] = float(fz.sum())
    return {'clip': getattr(clip, 'name', ''), 'frame': int(frame),
            'stance': [bool(c) for c in np.asarray(clip.contacts)[frame]],
            'seconds': n_frames / FRAME_RATE, 'window_s': window / FRAME_RATE, 'fidelity': fidelity,
            'offset_m': {name: float(dz[idx].mean()) if len(idx) else float('nan') for name, idx in regions.items()},
            'ground_load_n': load, 'weight_n': float(np.sum(model.node_mass)) * GRAVITY}


# -------------------------------------------------------------------------------------------- spring capacity

def capacity_planes(model: IguanaModel) -> dict:
    """Return the default `spring_capacity` planes: name -> rest x (m) of the joint of CAPACITY_PLANES' bone."""
    joints = rest_joint_positions(model.skeleton)
    return {name: float(joints[model.skeleton.index(bone), 0]) for name, bone in CAPACITY_PLANES.items()}


def spring_capacity(model: IguanaModel, x_planes: dict | tuple | list | None = None,
                    strain: float = CAPACITY_STRAIN) -> list[dict]:
    """
    Per vertical plane x = x0 of the rest mesh: the springs' bending moment at `strain` against gravity.

    `x_planes`: plane x positions (m), a {name: x} mapping, or None for `capacity_planes(model)`. Each spring
    crossing the plane pulls a_s l_rest,s strain along its direction; its x-component acts at the moment arm
    |z - z_c| of the crossing point about the crossing points' mean height z_c. Gravity moment: sum of
    m g |x - x0| over the nodes beyond the plane (the tail side for planes at or behind the pelvis joint, the
    front side otherwise). `required_strain_percent` = strain (%) x gravity moment / spring moment: the strain
    the springs need to hold that part up as a beam. The same figures with only main-body springs (no spring
    touching a leg node) are the `main_body_*` keys (the legs' springs crossing a plane near the hips do not
    hold the trunk up as a beam, but their large arms dominate the sum).
    """
    if x_planes is None:
        x_planes = capacity_planes(model)
    elif not isinstance(x_planes, dict):
        x_planes = {f'x={float(x):+.3f}': float(x) for x in x_planes}
    p = np.asarray(model.rest_positions, float)
    springs = np.asarray(model.springs)
    a, b = p[springs[:, 0]], p[springs[:, 1]]
    legs = np.asarray(model.node_part) >= PART_LIMB0
    main = ~legs[springs[:, 0]] & ~legs[springs[:, 1]]
    force = np.asarray(model.spring_stiffness) * np.asarray(model.spring_rest_lengths) * strain
    mass_weight = np.asarray(model.node_mass) * GRAVITY
    pelvis_x = float(rest_joint_positions(model.skeleton)[model.skeleton.index('pelvis'), 0])
    rows = []
    for name, x0 in x_planes.items():
        x0 = float(x0)
        crossing = (a[:, 0] - x0) * (b[:, 0] - x0) < 0
        tail_side = x0 <= pelvis_x
        far = p[:, 0] < x0 if tail_side else p[:, 0] > x0
        gravity = float(np.sum(mass_weight[far] * np.abs(p[far, 0] - x0)))
        row = {'plane': name, 'x_m': x0, 'far_side': 'tail' if tail_side else 'front', 'gravity_moment_nm': gravity}
        for prefix, subset in (('', crossing), ('main_body_', crossing & main)):
            moment = _bending_moment(a[subset], b[subset], force[subset], x0)
            row.update({f'{prefix}springs': int(subset.sum()), f'{prefix}spring_moment_nm': moment,
                        f'{prefix}required_strain_percent': 100.0 * strain * gravity / moment if moment > 0
                        else float('inf')})
        rows.append(row)
    return rows


def _bending_moment(a: np.ndarray, b: np.ndarray, force: np.ndarray, x0: float) -> float:
    """Sum of |F_x| |z - z_c| (N m) of springs from `a` to `b (k, 3)` pulling `force (k,)` N, crossing x = x0."""
    if not len(a):
        return 0.0
    d = b - a
    point = a + ((x0 - a[:, 0]) / d[:, 0])[:, None] * d
    arm = np.abs(point[:, 2] - point[:, 2].mean())
    return float(np.sum(force * np.abs(d[:, 0]) / np.linalg.norm(d, axis=1) * arm))


# ---------------------------------------------------------------------------------------------- planted feet

def statics_pipeline(scene: Scene | str, model: IguanaModel | None = None) -> Pipeline:
    """
    Return `pipeline.build_pipeline` of `scene` (a Scene or a scene name), optionally for another `model`.

    With `model`, its simulator (and spring-length stage) are built for it instead of the scene's model; the scene then
    names `model`'s resolution and preset.
    """
    scene = load_scene(scene) if isinstance(scene, str) else scene
    if model is not None:
        scene = dataclasses.replace(scene, model=ModelSpec(model.resolution, model.stiffness))
    pipe = build_pipeline(scene)
    if model is not None and model is not pipe.simulator.model:
        pipe.springs = pipe.lookahead.springs = spring_stage(scene, model)
        pipe.simulator = simulator_stage(scene, model=model, terrain=pipe.simulator.terrain)
    return pipe


def planted_feet(model: IguanaModel | None = None, scene: Scene | str = 'flat_walk', seconds: float = 4.0,
                 settle: float | None = None) -> dict:
    """
    Return the pipeline walking `scene` for `seconds` (with `model`, default the scene's), sampled every frame.

    Per foot, over the frames after `settle` s (default min(1 s, seconds / 4)) in which the clip says stance
    (`planner.reference_contacts`): the mean number of its sole nodes in contact (of how many), the fraction
    of those frames with none, the mean and coefficient of variation of its summed normal force (every node
    of the limb), the fraction of frames at the friction limit (|sum F_t| >= 0.95 mu sum F_n, mu the limb's
    mean friction coefficient); over the frames the clip says swing, the mean normal load it still carries.
    """
    if not (np.isfinite(seconds) and seconds > 0):
        raise InputError(f'planted feet: seconds must be positive, got {seconds!r}')
    settle = min(1.0, seconds / 4.0) if settle is None else float(settle)
    pipe = statics_pipeline(scene, model)
    model = pipe.simulator.model
    soles = [np.flatnonzero(model.node_tags[f]) for f in FEET]
    groups = ground_load_groups(model)
    limbs = [groups[f] for f in FEET]
    n_frames = int(round(seconds * FRAME_RATE))
    stance, touching, normal, tangential = [], [], [], []
    for _ in range(n_frames):
        frame = pipe.frame
        pipe.step()
        if frame / FRAME_RATE < settle:
            continue
        sim = pipe.simulator.sim
        contact, forces = sim.in_contact, sim.ground_forces()
        stance.append(pipe.planner.reference_contacts(frame))
        touching.append([int(contact[s].sum()) for s in soles])
        normal.append([forces[limb, 2].sum() for limb in limbs])
        tangential.append([np.hypot(*forces[limb, :2].sum(axis=0)) for limb in limbs])
    mu = [float(np.mean(pipe.simulator.sim.friction[limb])) for limb in limbs]
    stance, touching = np.array(stance, bool).reshape(-1, 4), np.array(touching).reshape(-1, 4)
    normal, tangential = np.array(normal).reshape(-1, 4), np.array(tangential).reshape(-1, 4)
    feet = {}
    for k, foot in enumerate(FEET):
        on, off = stance[:, k], ~stance[:, k]
        fn, ft = normal[on, k], tangential[on, k]
        limit = (fn > 0) & (ft >= FRICTION_LIMIT_FRACTION * mu[k] * fn)
        feet[foot] = {
            'sole_nodes': len(soles[k]), 'stance_frames': int(on.sum()), 'swing_frames': int(off.sum()),
            'sole_nodes_in_contact_mean': _stat(np.mean, touching[on, k]),
            'no_contact_fraction': _stat(np.mean, (touching[on, k] == 0).astype(float)),
            'normal_force_mean_n': _stat(np.mean, fn),
            'normal_force_cv': float(np.std(fn) / np.mean(fn)) if len(fn) and np.mean(fn) > 0 else float('nan'),
            'friction_limit_fraction': _stat(np.mean, limit.astype(float)),
            'swing_load_mean_n': _stat(np.mean, normal[off, k]),
        }
    return {'scene': pipe.scene.name, 'seconds': n_frames / FRAME_RATE, 'settle_s': settle,
            'frames': int(len(stance)), 'friction_limit_fraction_of_mu': FRICTION_LIMIT_FRACTION, 'feet': feet}


# ---------------------------------------------------------------------------------------------------- report

def mid_diagonal_frame(clip: Clip, stance: str = 'fl+hr') -> int:
    """
    Return the middle frame of the first run of `clip`'s frames whose stance flags are exactly the diagonal `stance`.

    `stance` is 'fl+hr' or 'fr+hl'; InputError if the clip has none.
    """
    frames = [i for i, flags in enumerate(np.asarray(clip.contacts, bool))
              if DIAGONALS.get(tuple(bool(f) for f in flags), ('',))[0] == stance]
    if not frames:
        raise InputError(f'clip {getattr(clip, "name", "")!r} has no {stance} frame')
    run = [frames[0]]
    for f in frames[1:]:
        if f != run[-1] + 1:
            break
        run.append(f)
    return run[len(run) // 2]


def statics_report(model: IguanaModel, clip_name: str = 'forward', sag_seconds: float = 2.0,
                   walk_seconds: float = 4.0, fidelity: str = 'balanced', scene: Scene | str = 'flat_walk') -> dict:
    """
    All four measurements of `model`.

    {'model', 'support', 'sag', 'sag_diagonal', 'springs', 'planted', 'wall_s'} (see each function). Support margins
    over the library clip `clip_name`; the sag over `sag_seconds` standing in the idle clip's first pose ('sag') and
    holding the middle fl+hr frame of `clip_name` ('sag_diagonal'); the walk over `walk_seconds` of `scene`; wall
    seconds of each part.
    """
    library = load_clip_library()
    if clip_name not in library:
        raise InputError(f'no clip {clip_name!r} in the clip library; clips: {", ".join(sorted(library))}')
    clip = library[clip_name]
    parts = {
        'support': lambda: support_margins(model, clip),
        'sag': lambda: static_sag(model, sag_seconds, fidelity, clip=library['idle']),
        'sag_diagonal': lambda: static_sag(model, sag_seconds, fidelity, clip=clip, frame=mid_diagonal_frame(clip)),
        'springs': lambda: spring_capacity(model),
        'planted': lambda: planted_feet(model, scene, walk_seconds),
    }
    report, wall = {'model': stiffness_summary(model)}, {}
    for name, measure in parts.items():
        start = time.perf_counter()
        report[name] = measure()
        wall[name] = time.perf_counter() - start
    report['wall_s'] = wall
    return report
