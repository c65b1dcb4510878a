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
The one CDR codec.

Serialized ROS 2 messages (little-endian plain CDR, XCDR1, as rmw_fastrtps and rosbag2 write them) read and written with
numpy, for the messages too large for the Python message classes (one object per point): visualization_msgs/Marker and
MarkerArray, trajectory_msgs/MultiDOFJointTrajectory (a motion clip: one Transform object per bone and frame) and
geometry_msgs/PoseArray (a reference pose, each frame).

A layout lists a message's fields in wire order; `CdrWriter.write` and `CdrReader.read` walk the same layout, so
the bytes built and the bytes read follow one definition (`MARKER`). Alignment is relative to the payload start,
after the 4-byte encapsulation header; an empty sequence has no padding. Reading needs numpy only (a bag reader
imports no message package for it); the message classes are imported when a marker is built.
"""
from __future__ import annotations

from dataclasses import dataclass
import functools
import struct
import typing

import numpy as np

from iguana_ros.constants import WORLD_FRAME
from iguana_ros.errors import InputError

if typing.TYPE_CHECKING:
    from builtin_interfaces.msg import Time

CDR_LE_HEADER = b'\x00\x01\x00\x00'
"""Encapsulation header of little-endian plain CDR."""

STRING = 'string'
"""Layout type of a CDR string (uint32 length including the NUL, the bytes, the NUL)."""

STRINGS = 'strings'
"""Layout type of a CDR sequence of strings (uint32 count, then each string)."""

_TRIANGLE_LIST, _ADD = 11, 0
"""visualization_msgs/Marker type and action codes of a triangle-list marker."""


@dataclass(frozen=True)
class Sequence:
    """Layout type of a CDR sequence of rows: uint32 row count, then `width` values of `dtype` per row."""

    dtype: str
    width: int


MARKER = (
    ('stamp', 'iI'), ('frame_id', STRING), ('ns', STRING), ('id', 'i'), ('type', 'i'), ('action', 'i'),
    ('pose', '7d'), ('scale', '3d'), ('color', '4f'), ('lifetime', 'iI'), ('frame_locked', '?'),
    ('points', Sequence('<f8', 3)), ('colors', Sequence('<f4', 4)),
    ('texture_resource', STRING), ('texture_stamp', 'iI'), ('texture_frame_id', STRING), ('texture_format', STRING),
    ('texture_data', Sequence('u1', 1)), ('uv_coordinates', Sequence('<f4', 2)),
    ('text', STRING), ('mesh_resource', STRING), ('mesh_file_filename', STRING), ('mesh_file_data', Sequence('u1', 1)),
    ('mesh_use_embedded_materials', '?'),
)
"""visualization_msgs/msg/Marker (Jazzy) in wire order; nested structs flattened: pose = position xyz then
orientation xyzw, texture = sensor_msgs/CompressedImage (header stamp, frame_id, format, data), mesh_file =
visualization_msgs/MeshFile (filename, data)."""


POSE_ARRAY = (('stamp', 'iI'), ('frame_id', STRING), ('poses', Sequence('<f8', 7)))
"""geometry_msgs/msg/PoseArray in wire order: each pose is position xyz then orientation xyzw."""

ODOMETRY = (('stamp', 'iI'), ('frame_id', STRING), ('child_frame_id', STRING), ('pose', '7d'),
            ('pose_covariance', '36d'), ('twist', '6d'), ('twist_covariance', '36d'))
"""nav_msgs/Odometry: header, child frame, pose (position, xyzw) and twist (linear, angular) with covariances."""

VALUES = Sequence('<f8', 1)
"""A sequence of float64."""

JOINT_STATE = (('stamp', 'iI'), ('frame_id', STRING), ('name', STRINGS), ('position', VALUES), ('velocity', VALUES),
               ('effort', VALUES))
"""sensor_msgs/msg/JointState in wire order."""

CLOCK = (('clock', 'iI'),)
"""rosgraph_msgs/msg/Clock: one builtin_interfaces/Time."""

WRENCH_STAMPED = (('stamp', 'iI'), ('frame_id', STRING), ('wrench', '6d'))
"""geometry_msgs/msg/WrenchStamped in wire order: header, then force xyz and torque xyz."""


def _alignment(fmt: str) -> int:
    """CDR alignment of a struct format: the size of its first primitive (every field here is homogeneous)."""
    return struct.calcsize('<' + fmt.lstrip('0123456789')[0])


@functools.lru_cache(maxsize=None)
def _default(kind) -> object:
    """Return the value a field takes when a writer is not given it: zeros, '' or an empty sequence (immutable)."""
    if kind == STRING:
        return ''
    if kind == STRINGS:
        return ()
    if isinstance(kind, Sequence):
        empty = np.zeros((0, kind.width), kind.dtype)
        empty.flags.writeable = False
        return empty
    return tuple(0 for _ in struct.unpack('<' + kind, bytes(struct.calcsize('<' + kind))))


class CdrWriter:
    """Builds one serialized message: the header, then fields appended in order."""

    def __init__(self) -> None:
        """Start an empty payload after the little-endian header."""
        self.parts: list[bytes] = [CDR_LE_HEADER]
        self.size = 0

    def _put(self, data: bytes, align: int) -> None:
        """Append `data` at the next `align`-aligned payload offset."""
        pad = (-self.size) % align
        if pad:
            self.parts.append(b'\x00' * pad)
        self.parts.append(data)
        self.size += pad + len(data)

    def pack(self, fmt: str, *values) -> None:
        """Primitives of struct format `fmt` (aligned to its first primitive)."""
        self._put(struct.pack('<' + fmt, *values), _alignment(fmt))

    def string(self, text: str) -> None:
        """Write a CDR string."""
        raw = text.encode() + b'\x00'
        self.pack('I', len(raw))
        self._put(raw, 1)

    def strings(self, texts) -> None:
        """Write a CDR sequence of strings."""
        self.pack('I', len(texts))
        for text in texts:
            self.string(text)

    def sequence(self, rows: np.ndarray, kind: Sequence) -> None:
        """Write a sequence: the row count, then the rows' raw data (row-major, `kind.dtype`)."""
        data = np.ascontiguousarray(rows, dtype=kind.dtype).reshape(-1, kind.width)
        self.pack('I', data.shape[0])
        if data.size:
            self._put(data.tobytes(), data.dtype.itemsize)

    def write(self, layout: tuple, values: dict) -> None:
        """Every field of `layout` from `values` (by name; missing ones take zeros, '' or empty)."""
        for name, kind in layout:
            value = values[name] if name in values else _default(kind)
            if kind == STRING:
                self.string(value)
            elif kind == STRINGS:
                self.strings(value)
            elif isinstance(kind, Sequence):
                self.sequence(value, kind)
            else:
                self.pack(kind, *(value if isinstance(value, (tuple, list, np.ndarray)) else (value,)))

    def to_bytes(self) -> bytes:
        """Return the serialized message."""
        return b''.join(self.parts)


class CdrReader:
    """Reads the fields of one serialized message in order; struct.error or ValueError if it ends early."""

    def __init__(self, data: bytes, what: str = 'message') -> None:
        """`InputError` naming `what` unless `data` opens with the little-endian CDR header."""
        if len(data) < 4 or data[:4] != CDR_LE_HEADER:
            raise InputError(f'{what} bytes are not little-endian CDR (expected header 00 01 00 00)')
        self.data, self.pos = data, 0

    def take(self, fmt: str) -> tuple:
        """Primitives of struct format `fmt` at the next aligned offset."""
        self.pos += (-self.pos) % _alignment(fmt)
        values = struct.unpack_from('<' + fmt, self.data, 4 + self.pos)
        self.pos += struct.calcsize('<' + fmt)
        return values

    def string(self) -> str:
        """Return a CDR string, undecodable bytes replaced."""
        (n,) = self.take('I')
        if 4 + self.pos + n > len(self.data):
            raise ValueError(f'string of {n} bytes runs past the end of the message')
        text = self.data[4 + self.pos:4 + self.pos + max(n - 1, 0)].decode(errors='replace')
        self.pos += n
        return text

    def strings(self) -> list[str]:
        """Return a CDR sequence of strings."""
        (n,) = self.take('I')
        if n > len(self.data):
            raise ValueError(f'{n} strings cannot fit in {len(self.data)} bytes')
        return [self.string() for _ in range(n)]

    def sequence(self, kind: Sequence) -> np.ndarray:
        """Return a sequence as an array `(n, kind.width)` (a read-only view of the bytes; float64 zeros when empty)."""
        (n,) = self.take('I')
        if n == 0:
            return np.zeros((0, kind.width))
        dtype = np.dtype(kind.dtype)
        self.pos += (-self.pos) % dtype.itemsize
        values = np.frombuffer(self.data, dtype, n * kind.width, 4 + self.pos).reshape(n, kind.width)
        self.pos += values.nbytes
        return values

    def read(self, layout: tuple, until: str | None = None) -> dict:
        """{name: value} of the fields of `layout` (struct fields as tuples), stopping after field `until`."""
        out = {}
        for name, kind in layout:
            if kind == STRING:
                out[name] = self.string()
            elif kind == STRINGS:
                out[name] = self.strings()
            elif isinstance(kind, Sequence):
                out[name] = self.sequence(kind)
            else:
                out[name] = self.take(kind)
            if name == until:
                break
        return out


def write_layout(layout: tuple, values: dict) -> bytes:
    """Return one serialized message of `layout` from `values` (see `CdrWriter.write`)."""
    writer = CdrWriter()
    writer.write(layout, values)
    return writer.to_bytes()


def read_layout(data: bytes, layout: tuple, what: str, type_name: str) -> dict:
    """{name: value} of every field of `layout` in `data`; InputError naming `what` and `type_name` if it is not one."""
    reader = CdrReader(data, f'{what}: message')
    try:
        return reader.read(layout)
    except (struct.error, ValueError) as exc:
        raise InputError(f'{what}: message is truncated or not {type_name}: {exc}') from exc


class Trajectory(typing.NamedTuple):
    """The fields of a trajectory_msgs/MultiDOFJointTrajectory without twists, as numpy arrays."""

    stamp: tuple                # (sec, nanosec) of header.stamp
    frame_id: str
    joint_names: list
    times: np.ndarray           # (n_points,) s, time_from_start
    translations: np.ndarray    # (n_points, n_joints, 3) m
    rotations: np.ndarray       # (n_points, n_joints, 4) xyzw


TRANSFORM = Sequence('<f8', 7)
"""A sequence of geometry_msgs/Transform: translation xyz then rotation xyzw."""


def multi_dof_trajectory_cdr(trajectory: Trajectory) -> bytes:
    """
    Return serialized bytes of the MultiDOFJointTrajectory of `trajectory` (no velocities or accelerations).

    The bytes rclpy writes for the message `conversions.multi_dof_trajectory_msg` builds, without its per-transform
    Python objects (a stride clip holds 21 x 34).
    """
    writer = CdrWriter()
    writer.pack('iI', *trajectory.stamp)
    writer.string(trajectory.frame_id)
    writer.strings(trajectory.joint_names)
    frames = np.concatenate([trajectory.translations, trajectory.rotations], axis=2)
    ns = np.round(np.asarray(trajectory.times, dtype=np.float64) * 1e9).astype(np.int64)
    writer.pack('I', len(frames))
    for transforms, t in zip(frames, ns.tolist()):
        writer.sequence(transforms, TRANSFORM)
        writer.pack('II', 0, 0)                     # no velocities, no accelerations
        writer.pack('iI', t // 1_000_000_000, t % 1_000_000_000)
    return writer.to_bytes()


def multi_dof_trajectory_from_cdr(data: bytes, what: str = 'motion_clip') -> Trajectory:
    """Return the `Trajectory` of serialized MultiDOFJointTrajectory bytes; InputError naming `what` if not one."""
    reader = CdrReader(data, f'{what}: message')
    try:
        stamp = reader.take('iI')
        frame_id = reader.string()
        names = reader.strings()
        n_names = len(names)
        (n_points,) = reader.take('I')
        if n_points > len(data):
            raise ValueError(f'{n_points} points cannot fit in {len(data)} bytes')
        frames, times = [], []
        for _ in range(n_points):
            transforms = reader.sequence(TRANSFORM)
            if len(transforms) != n_names:
                raise InputError(f'{what}: trajectory points hold {len(transforms)} transforms, expected {n_names} '
                                 '(one per joint name)')
            for _ in range(2):                          # velocities, accelerations: Twists of 6 doubles
                (twists,) = reader.take('I')
                if twists:
                    reader.pos += (-reader.pos) % 8 + 48 * twists
            sec, nsec = reader.take('iI')
            frames.append(transforms)
            times.append(sec + nsec * 1e-9)
    except (struct.error, ValueError) as exc:
        raise InputError(f'{what}: message is truncated or not a MultiDOFJointTrajectory: {exc}') from exc
    stacked = np.array(frames, dtype=np.float64).reshape(n_points, n_names, 7)
    return Trajectory(stamp, frame_id, names, np.array(times), stacked[:, :, :3], stacked[:, :, 3:])


def pose_array_cdr(stamp: tuple, frame_id: str, positions: np.ndarray, orientations: np.ndarray) -> bytes:
    """Return serialized PoseArray bytes of positions `(n, 3)` and orientations `(n, 4)` xyzw stamped (sec, nanosec)."""
    return write_layout(POSE_ARRAY, {'stamp': stamp, 'frame_id': frame_id,
                                     'poses': np.concatenate([positions, orientations], axis=1)})


def pose_array_from_cdr(data: bytes, what: str = 'PoseArray') -> tuple:
    """(stamp (sec, nanosec), frame_id, positions `(n, 3)`, orientations `(n, 4)`) of PoseArray bytes, or InputError."""
    fields = read_layout(data, POSE_ARRAY, what, 'a PoseArray')
    poses = np.array(fields['poses'], dtype=np.float64)
    return fields['stamp'], fields['frame_id'], poses[:, :3], poses[:, 3:]


def odometry_from_cdr(data: bytes, what: str = 'Odometry') -> tuple:
    """
    (stamp (sec, nanosec), frame_id, pose `(7,)` position + xyzw, twist `(6,)` linear + angular) of Odometry bytes.

    InputError if they are not one.
    """
    fields = read_layout(data, ODOMETRY, what, 'an Odometry')
    return fields['stamp'], fields['frame_id'], np.array(fields['pose']), np.array(fields['twist'])


def odometry_cdr(stamp: tuple, frame_id: str, child_frame_id: str, pose: np.ndarray, twist: np.ndarray) -> bytes:
    """Return serialized Odometry bytes of pose `(7,)` position + xyzw and twist `(6,)` (zero covariances)."""
    return write_layout(ODOMETRY, {'stamp': stamp, 'frame_id': frame_id, 'child_frame_id': child_frame_id,
                                   'pose': np.asarray(pose, np.float64).tolist(),
                                   'twist': np.asarray(twist, np.float64).tolist()})


def tf_message_cdr(stamp: tuple, parents: list, children: list, translations: np.ndarray,
                   rotations: np.ndarray) -> bytes:
    """
    Return serialized tf2_msgs/TFMessage bytes: one TransformStamped per child, all stamped (sec, nanosec).

    `parents` and `children` are frame names `(n,)`, `translations` `(n, 3)` m and `rotations` `(n, 4)` xyzw.
    """
    rows = np.concatenate([np.asarray(translations, np.float64), np.asarray(rotations, np.float64)], axis=1)
    writer = CdrWriter()
    writer.pack('I', len(rows))
    for parent, child, row in zip(parents, children, rows):
        writer.pack('iI', *stamp)
        writer.string(parent)
        writer.string(child)
        writer.pack('7d', *row)
    return writer.to_bytes()


def tf_message_from_cdr(data: bytes, what: str = 'TFMessage') -> list[tuple]:
    """Return [(stamp (sec, nanosec), parent, child, translation `(3,)`, rotation `(4,)` xyzw)] of TFMessage bytes."""
    try:
        reader = CdrReader(data, what)
        transforms = []
        for _ in range(reader.take('I')[0]):
            stamp = reader.take('iI')
            parent, child = reader.string(), reader.string()
            row = np.array(reader.take('7d'))
            transforms.append((stamp, parent, child, row[:3], row[3:]))
    except (struct.error, ValueError) as exc:
        raise InputError(f'{what}: message is truncated or not a TFMessage: {exc}') from exc
    return transforms


def joint_state_cdr(stamp: tuple, frame_id: str, names: list, position: np.ndarray,
                    effort: np.ndarray | None = None) -> bytes:
    """Return serialized JointState bytes: `names`, position `(n,)`, no velocity, effort `(m,)` (None = empty)."""
    return write_layout(JOINT_STATE, {'stamp': stamp, 'frame_id': frame_id, 'name': names, 'position': position,
                                      **({} if effort is None else {'effort': effort})})


def joint_state_from_cdr(data: bytes, what: str = 'JointState') -> dict:
    """{stamp (sec, nanosec), frame_id, name, position `(n,)`, velocity, effort} of JointState bytes, or InputError."""
    fields = read_layout(data, JOINT_STATE, what, 'a JointState')
    for key in ('position', 'velocity', 'effort'):
        fields[key] = fields[key].reshape(-1)
    return fields


def clock_cdr(stamp: tuple) -> bytes:
    """Return serialized rosgraph_msgs/Clock bytes of `stamp` (sec, nanosec)."""
    return write_layout(CLOCK, {'clock': stamp})


def clock_from_cdr(data: bytes, what: str = 'clock') -> tuple[int, int]:
    """Return the time (sec, nanosec) of serialized rosgraph_msgs/Clock bytes; InputError naming `what` if not one."""
    return read_layout(data, CLOCK, what, 'a Clock')['clock']


def wrench_stamped_from_cdr(data: bytes, what: str = 'WrenchStamped') -> tuple:
    """(stamp (sec, nanosec), frame_id, force `(3,)`, torque `(3,)`) of WrenchStamped bytes, or InputError."""
    fields = read_layout(data, WRENCH_STAMPED, what, 'a WrenchStamped')
    wrench = np.array(fields['wrench'])
    return fields['stamp'], fields['frame_id'], wrench[:3], wrench[3:]


def header_stamp(data: bytes) -> tuple[int, int]:
    """header.stamp (sec, nanosec) of a serialized stamped message (it opens the payload); struct.error if short."""
    return struct.unpack_from('<iI', data, 4)


def header_stamp_ns(data: bytes) -> int:
    """header.stamp (ns) of a serialized stamped message."""
    sec, nsec = header_stamp(data)
    return sec * 1_000_000_000 + nsec


@dataclass
class MarkerData:
    """The fields of a visualization_msgs/Marker that rendering uses, as numpy arrays."""

    ns: str
    type: int  # noqa: A003 - visualization_msgs/Marker.type
    action: int
    position: np.ndarray        # (3,) m
    orientation: np.ndarray     # (4,) xyzw
    scale: np.ndarray           # (3,)
    color: np.ndarray           # (4,) RGBA
    points: np.ndarray          # (n, 3) m
    colors: np.ndarray          # (n, 4) RGBA


def _marker_data(fields: dict) -> MarkerData:
    """`MarkerData` of the fields `CdrReader.read(MARKER)` returned."""
    pose = np.array(fields['pose'])
    return MarkerData(fields['ns'], fields['type'][0], fields['action'][0], pose[:3], pose[3:],
                      np.array(fields['scale']), np.array(fields['color'], dtype=np.float64),
                      fields['points'].astype(np.float64), fields['colors'].astype(np.float64))


class TriangleListMarkerWriter:
    """
    Serialized triangle-list Markers of one indexed mesh, for a frame loop.

    The bytes of `conversions.triangle_list_marker` for triangles `(n_t, 3)` over `n_vertices` vertices: the layout is
    written once, and each `write` copies it and fills in the stamp, the per-corner points and colours.
    """

    def __init__(self, triangles, n_vertices: int, frame_id: str = WORLD_FRAME, ns: str = 'iguana',
                 marker_id: int = 0) -> None:
        """Validate the triangles (`conversions.triangle_soup`) and lay out their message once."""
        from iguana_ros.ros.conversions import triangle_soup

        self.n_vertices = int(n_vertices)
        points, rgba = triangle_soup(np.zeros((self.n_vertices, 3)), triangles, np.zeros((self.n_vertices, 4)))
        self.corners = np.asarray(triangles, np.intp).reshape(-1)
        values = {'stamp': (0, 0), 'frame_id': frame_id, 'ns': ns, 'id': int(marker_id), 'type': _TRIANGLE_LIST,
                  'action': _ADD, 'pose': (0.0,) * 6 + (1.0,), 'scale': (1.0, 1.0, 1.0), 'color': (1.0, 1.0, 1.0, 1.0),
                  'points': points, 'colors': rgba}
        head = CdrWriter()
        head.write(MARKER[:[name for name, _ in MARKER].index('points')], values)
        head.pack('I', len(self.corners))
        payload_points = head.size + (-head.size) % 8
        self.points_at = len(CDR_LE_HEADER) + payload_points
        self.colors_at = self.points_at + 24 * len(self.corners) + 4      # after the colours' uint32 count
        self.template = write_layout(MARKER, values)

    def write(self, vertices, colors, stamp: float | Time = 0.0) -> bytes:
        """Return the bytes for vertices `(n_vertices, 3)` m, RGBA `(n_vertices, 4)` and a stamp (s or Time)."""
        from builtin_interfaces.msg import Time  # noqa: F811 (the class itself, for isinstance)

        from iguana_ros.ros.conversions import time_to_msg
        from iguana_ros.validation import validate_array

        verts = validate_array('vertices', vertices, (self.n_vertices, 3))
        rgba = validate_array('colors', colors, (self.n_vertices, 4)).astype(np.float32)
        t = stamp if isinstance(stamp, Time) else time_to_msg(stamp)
        n = len(self.corners)
        buf = bytearray(self.template)
        struct.pack_into('<iI', buf, len(CDR_LE_HEADER), t.sec, t.nanosec)
        np.take(verts, self.corners, axis=0, out=np.frombuffer(buf, '<f8', 3 * n, self.points_at).reshape(n, 3))
        np.take(rgba, self.corners, axis=0, out=np.frombuffer(buf, '<f4', 4 * n, self.colors_at).reshape(n, 4))
        return bytes(buf)


def triangle_list_marker_cdr(vertices, triangles, colors, stamp: float | Time = 0.0,
                             frame_id: str = WORLD_FRAME, ns: str = 'iguana',
                             marker_id: int = 0) -> bytes:
    """
    Return the serialized bytes of exactly the Marker `conversions.triangle_list_marker` builds.

    The Marker is built from vertices `(n_v, 3)`, triangles `(n_t, 3)` and RGBA `(n_v, 4)`; in a frame loop, a
    `TriangleListMarkerWriter` lays the message out once.
    """
    from iguana_ros.validation import validate_array

    verts = validate_array('vertices', vertices, (None, 3))
    return TriangleListMarkerWriter(triangles, len(verts), frame_id, ns, marker_id).write(verts, colors, stamp)


def triangle_list_from_cdr(data: bytes) -> tuple[np.ndarray, np.ndarray]:
    """Points `(3*n_t, 3)` and RGBA `(3*n_t, 4)` (float64) of serialized Marker bytes (read up to its colours)."""
    reader = CdrReader(data, 'marker')
    try:
        fields = reader.read(MARKER, until='colors')
    except (struct.error, ValueError) as exc:
        raise InputError(f'marker bytes are truncated or not a visualization_msgs/Marker: {exc}') from exc
    return fields['points'].astype(np.float64), fields['colors'].astype(np.float64)


def marker_array_from_cdr(data: bytes, what: str = 'scene_markers') -> list[MarkerData]:
    """
    Return the markers of a serialized visualization_msgs/MarkerArray (no per-point objects).

    InputError naming `what` if the bytes are not one.
    """
    reader = CdrReader(data, f'{what}: message')
    try:
        (n,) = reader.take('I')
        return [_marker_data(reader.read(MARKER)) for _ in range(n)]
    except (struct.error, ValueError) as exc:
        raise InputError(f'{what}: message is truncated or not a MarkerArray: {exc}') from exc
