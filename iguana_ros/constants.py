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

"""Physical constants and paper parameters, in SI units; the one place they are written."""

GRAVITY = 9.8
"""Gravitational acceleration, m/s^2 (paper, Section VIII)."""

BODY_MASS = 4.0
"""Total mass of the adult iguana model, kg (Section VIII)."""

BODY_LENGTH = 0.85
"""Snout-to-tail-tip length of the adult iguana model, m (Section VIII)."""

TAIL_FRACTION = 0.66
"""Tail length as a fraction of total length (green iguana anatomy)."""

FRICTION_COEFFICIENT = 1.0
"""Coulomb friction coefficient between body and terrain (Section VIII)."""

SIM_DT = 1.0 / 1200.0
"""Integration time step of the soft-body simulation, s (Section VIII)."""

FRAME_RATE = 30.0
"""Reference-pose update rate (motion capture rate), Hz (Section VIII)."""

STEPS_PER_FRAME = 40
"""Simulator steps per reference frame: (1/30 s) / (1/1200 s)."""

PUSH_FORCE = 40.0
"""Magnitude of the Section VIII-D push, N."""

PUSH_DURATION = 0.1
"""Duration of the Section VIII-D push, s."""

N_MARKERS = 15
"""Motion-capture markers: 4 feet, 3 tail, 1 head, 7 body (Section IV, Figure 3)."""

WORLD_FRAME = 'world'
"""frame_id of the fixed world frame used by every stamped message."""

ODOM_FRAME = 'odom'
"""REP-105 odometry frame: a static identity child of the world frame on /tf_static."""

MAP_FRAME = 'map'
"""REP-105 map frame: coincides with the world frame (the terrain is the map)."""

GOAL_FRAMES = (WORLD_FRAME, MAP_FRAME, ODOM_FRAME)
"""frame_ids a goal or route may have: frames that coincide with the world frame, so no transform is needed."""

BASE_FRAME = 'base_link'
"""REP-105 frame of the iguana's root (pelvis): child_frame_id of iguana_state, on /tf (under the frame_prefix)."""

# --- soft-body simulator (iguana_ros.physics) -------------------------------------------------------------------
CONTACT_STIFFNESS = 1.0e6
"""Ground penalty stiffness per kg of node mass, 1/s² (N/m per kg): a node resting alone sinks g/1e6 ≈ 0.01 mm; a
sole node carrying a stance foot's 10-20 N sinks ~0.5-1 mm (at 1e5 the feet sank 3-6 mm and the body with them)."""

CONTACT_DAMPING_RATIO = 10.0
"""Damping ratio of each node's ground spring-damper with respect to its own contact mass (normal force never
pulls). A foot's 5-10 contact nodes (~0.01 kg each) carry ~1 kg of body, so a ratio of 1 per node leaves the
loaded foot ringing on its contact springs at ~35 Hz with ζ ≈ 0.2 (sampled normal force of a stance foot
jumping between 1 and 28 N from frame to frame), and the foot slides in every light phase. Measured on the
medium body walking flat_walk (8 s), summed stance-foot slip per stride at ratios 1, 3, 5, 10, 20: 0.111,
0.094, 0.086, 0.068, 0.062 m."""

FRICTION_STIFFNESS = 1.0e6
"""Stiffness per kg (1/s²) of the tangential stick-anchor spring that realises static Coulomb friction (a
node of 0.01 kg: 10 kN/m; 1e5 let stuck feet creep: summed slip 0.068 -> 0.054 m per stride with 1e6)."""

RAYLEIGH_ALPHA = 0.2
"""Mass-proportional Rayleigh damping α of C = αM + βK, 1/s."""

RAYLEIGH_BETA = 2.0e-3
"""Stiffness-proportional Rayleigh damping β of C = αM + βK, s."""

BODY_CONTACT_STIFFNESS = 4.0e4
"""Penalty stiffness of one body's surface node inside another body, N/m (at most the stable one for the block
length, `physics.body_contact`). Not per kg as the ground's: surface node masses span 0.2 g to 0.2 kg. A walking
iguana's head pressed into another sank 1-3 mm (coarse and medium, balanced); 5e3 let it in 8 mm."""

BODY_CONTACT_DAMPING_RATIO = 0.5
"""Damping ratio of a body-body contact node's spring-damper (normal damping never pulls)."""

BODY_CONTACT_PERIOD = 1.0 / 1200.0
"""Seconds the body-body contact forces are held before they are recomputed (a step of the balanced preset)."""

MAX_NODE_SPEED = 100.0
"""Speed (m/s) above which a node's motion is declared diverged (far above any iguana or push response)."""

MAX_PENETRATION = 0.1
"""Depth (m) below the terrain at which a node is declared diverged (resting nodes sink ~0.1–1 mm)."""

FALL_TILT = 1.0471975511965976
"""Root tilt (roll or pitch, from the world's up axis) beyond which the iguana counts as fallen, rad (60°)."""

FALL_HOLD = 1.0
"""Seconds the root must stay tilted beyond FALL_TILT before a run ends as fallen (a push may tip it briefly)."""

# --- Synthetic lizard gait (iguana_ros.motion.gait); sources in docs/METHODS.md "Motion data" ---
SNOUT_VENT_LENGTH = BODY_LENGTH * (1.0 - TAIL_FRACTION)
"""Snout-vent length of the adult iguana model, m (0.29 m)."""

TROT_STRIDE_FREQUENCY = 1.5
"""Stride frequency of the slow trot, Hz: 20 frames per stride at 30 Hz (assumed; Fieler & Jayne 1998
measured 3.9 Hz at 0.5 m/s in a 0.1 m-SVL lizard, lower for a 3x longer animal)."""

TROT_DUTY_FACTOR = 0.65
"""Fraction of a stride a foot is on the ground (Fieler & Jayne 1998: 0.63 at their slowest speed)."""

TROT_STRIDE_LENGTH = 0.55 * SNOUT_VENT_LENGTH
"""Stride length of the slow trot, m (0.55 SVL, 0.16 m; assumed, the longest the model's legs reach)."""

WALK_STRIDE_FREQUENCY = 1.2
"""Stride frequency of the slow walk (a walking trot), Hz: 25 frames per stride (assumed; lizards keep the diagonal
footfalls at low speed with a higher duty factor, Fieler & Jayne 1998)."""

WALK_DUTY_FACTOR = 0.75
"""Fraction of a stride a foot is on the ground in the slow walk (assumed; above the trot's 0.65)."""

WALK_STRIDE_LENGTH = 0.6 * TROT_STRIDE_LENGTH
"""Stride length of the slow walk, m (0.096 m: 0.12 m/s at WALK_STRIDE_FREQUENCY)."""

FAST_STRIDE_FREQUENCY = 2.0
"""Stride frequency of the fast trot, Hz: 15 frames per stride (assumed; speed grows by frequency at a stride length
the legs already reach at their limit)."""

FAST_DUTY_FACTOR = 0.55
"""Fraction of a stride a foot is on the ground in the fast trot (Fieler & Jayne 1998: duty falls with speed)."""

FAST_TURN_PER_STRIDE = 0.175
"""Heading change of a turn in the fast trot, rad per stride (10 deg: 20 deg/s at FAST_STRIDE_FREQUENCY, a radius of
~0.9 m; enough to hold a course, where the trot's 15 deg turns are for turning)."""

PIVOT_TURN_PER_STRIDE = 0.698
"""Heading change of a turn on the spot, rad per stride (40 deg; at 45 deg a stance foot of the right pivot leaves the
legs' reach whatever the centre and bend). Its stride frequency is the fast trot's: the soft body measured 33-38 deg
per stride at 2 Hz (65-76 deg/s), 28 deg at the trot's 1.5 Hz (42 deg/s) and 32 deg at the walk's 1.2 Hz."""

PIVOT_CENTRE = 0.09
"""Distance (m) ahead of the pelvis of the point a turn on the spot rotates about, between the girdles (with
PIVOT_TURN_BEND, the middle of the centres 0.08-0.10 m at which every stance foot of both pivots stays within the legs'
reach)."""

PIVOT_TURN_BEND = 0.1
"""Fraction of a turn on the spot held as a static trunk bend toward the turn."""

PIVOT_DUTY_FACTOR = 0.5
"""Fraction of a stride a foot is on the ground in a turn on the spot: the body turns ~22 deg over a stance, the
most the sprawled legs follow (at the walk's 0.75 a planted foot leaves their reach)."""

SHARP_DUTY_FACTOR = 0.55
"""Fraction of a stride a foot is on the ground in a sharp turn (reach-limited as PIVOT_DUTY_FACTOR)."""

SHARP_TURN_PER_STRIDE = 0.524
"""Heading change of a sharp turn, rad per walk stride (30 deg at the walk's stride length: radius ~0.18 m)."""

SHARP_TURN_BEND = 0.75
"""Fraction of a sharp turn's heading change per stride held as a static trunk bend toward the turn (the trot's
turns hold 0.5; at 0.5 the outer fore foot leaves its reach late in stance)."""

PELVIC_YAW_AMPLITUDE = 0.21
"""Pelvic rotation in the horizontal plane, rad, amplitude (±12°; Fieler & Jayne 1998 report 36° peak to
peak in Dipsosaurus, we assume 24° for a slow trot)."""

MARKER_NOISE_STD = 0.001
"""Standard deviation of synthetic marker noise per axis, m (assumed optical-capture quality)."""

# --- what the nodes accept from a topic (iguana_ros.validation) ---------------------------------------------------
DESIRED_SHRINK_FACTOR = 10.0
"""Each desired spring length (spring_rest_lengths) must be above its rest length / this factor, else the simulator
rejects the frame and the spring-length node does not publish it. Measured (desired / rest over every spring and
frame of pipeline.run): the six shipped scenes 0.47 .. 1.42 on the medium mesh, 0.49 .. 1.54 on the coarse one; the
32 randomized terrains of `iguana bench locomotion --suite terrains --terrains 32 --seed 0` (medium) 0.48 .. 1.42
without adaptation and 0.17 .. 2.09 with it (10 cm bumps at 0.5 m, where the feet's IK folds and stretches the legs).
Shortening is benign: every validated pattern of `iguana bench faults limits` at 1/10 is simulated stably."""

DESIRED_STRETCH_FACTOR = 4.0
"""Each desired spring length must be below its rest length x this factor. Lengthening is what diverges: on the
coarse mesh with the `fast` preset, 22-25 springs at 7-8x rest from the first frame (RMS log strain 0.3) diverge in
1-2 of 20 tries (a node above MAX_NODE_SPEED), 18 at 10x in 2 of 5 (the probe's 42 springs at 9.99x on medium: 10 of
20 before the first frame ramped from rest), none at 6x; 4 leaves 1.5x below that and 1.9x above the 2.09 measured.
`iguana bench faults limits` draws validated messages at random (every mesh and preset): none diverges."""

DESIRED_STRAIN_RMS = 0.3
"""Largest RMS over all springs of |ln(desired / rest)| accepted in one frame (the commanded shape's overall
strain): measured at most 0.042 in the shipped scenes (medium; 0.067 coarse) and 0.102 on the randomized terrains
with adaptation (same runs as DESIRED_SHRINK_FACTOR), ~3x margin. Every length x2 at once (0.69) diverges within
one frame on the coarse mesh, x1.5 (0.41) does not; random factors within 1/5.5 .. 5.5 (RMS ~1) diverge too."""

MAX_PUSH_BODY_DELTA_V = 5.0
"""Largest velocity change a push (or the pushes acting at once) may give the whole body, m/s: impulse / BODY_MASS,
the impulse being the force times the whole frames it acts (iguana_ros.physics.pushes.push_active_time). 5 m/s
throws the 4 kg iguana at most ~2.5 m and lands it at most as fast as a 1.3 m fall; the paper's push (40 N x 0.1 s)
is 1 m/s. The probe's 1 kN x 0.1 s (25 m/s) threw it 20 m. What the body then does (walks on, falls, leaves the
terrain) is the run's outcome (iguana_ros.physics.body_watch), never a divergence: see MAX_PUSH_REGION_DELTA_V."""

MAX_PUSH_REGION_DELTA_V = 50.0
"""Largest velocity change a push may give the nodes it acts on, m/s: impulse / the mass of its region (the force
is spread by mass, iguana_ros.physics.pushes.region_force). Measured standing on flat ground, 1 s after pushes of
1, 3 and 15 frames in 4 directions on each region: nothing diverges at 50 m/s on coarse/medium (fast, balanced);
the first divergences (speed bound, tail pushed into the ground) come at 200 m/s. The feet (17 g of 4 kg) thus take
at most 0.85 N s; `iguana bench faults limits` draws pushes within both limits on every mesh and preset."""

MAX_FRAME_GAP = 300
"""A frame-stamped input (iguana_state, motion_clip, reference_pose, spring_rest_lengths) stamped more than this
many frames (10 s) ahead of the last frame a node handled is rejected: frames advance one at a time, so such a
stamp comes from another clock (a wall-clock stamp) and would make every later frame look stale."""

WORLD_MARGIN = 5.0
"""How far beyond the terrain's side length a coordinate of the body's root, a clip root or a reference bone may
lie, m (|x|, |y|, |z| <= extent + margin): the goals lie within half the extent, so a body still walking is far
inside; 1e9 m is a broken message."""

QUATERNION_NORM_TOLERANCE = 1e-6
"""Largest |norm - 1| of an orientation accepted from a topic (the nodes' own are unit to 1e-15)."""

BONE_LENGTH_TOLERANCE = 1e-6
"""Largest misfit (m) accepted between a received bone frame's distance to its parent (or a clip's bone
translation) and the skeleton's offset (the adaptation's poses fit to 4e-16 m)."""

MAX_CLIP_FRAMES = 300
"""Most points a motion_clip may hold (10 s at 30 Hz; the library's stride clips have 21)."""

MAX_SCHEDULE_AHEAD = 3600.0
"""A goal stamped further ahead of simulated time than this (s) is taken as a wall-clock stamp: adopted now (the
planner's rule; `iguana run`'s progress follows it to know which goal is current)."""
