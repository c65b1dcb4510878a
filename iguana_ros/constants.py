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

BASE_FRAME = 'iguana/base_link'
"""child_frame_id of the iguana's root (pelvis) in odometry."""
