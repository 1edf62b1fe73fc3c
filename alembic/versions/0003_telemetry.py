"""telemetry: motion and signals at 30+ Hz in compressed chunks (replacing 10 Hz state samples), camera frames,
the recorder's heartbeat and process (a session found open after a crash is closed as interrupted)

Revision ID: 0003
Revises: 0002
Create Date: 2026-11-25 09:00:00

The state samples of existing sessions are converted into telemetry chunks (and back on downgrade). The chunk
encoding is written out here rather than imported, so that this migration keeps doing what it did when it was
written (format 1 of app/sessions/telemetry_codec.py).
"""

from __future__ import annotations

import math
import struct
import zlib
from datetime import UTC, datetime

import numpy as np
import sqlalchemy as sa
from alembic import op

revision = '0003'
down_revision = '0002'
branch_labels = None
depends_on = None

_HEADER = struct.Struct("<4sII")
_CHUNK_ROWS = 10  # a second of the old 10 Hz samples


def _encode(rows: np.ndarray) -> bytes:
    n, width = rows.shape
    times = np.ascontiguousarray(rows[:, :2], dtype="<f8")
    values = np.ascontiguousarray(rows[:, 2:], dtype="<f4")
    shuffled = values.view(np.uint8).reshape(n, -1, 4).transpose(2, 1, 0).tobytes()
    return _HEADER.pack(b"HTC1", n, width) + zlib.compress(times.tobytes() + shuffled, 6)


def _decode(blob: bytes) -> np.ndarray:
    _, n, width = _HEADER.unpack_from(blob)
    raw = zlib.decompress(blob[_HEADER.size:])
    times = np.frombuffer(raw[:n * 16], dtype="<f8").reshape(n, 2)
    values = np.frombuffer(raw[n * 16:], dtype=np.uint8).reshape(4, width - 2, n).transpose(2, 1, 0)
    return np.hstack([times, np.ascontiguousarray(values).view("<f4").reshape(n, width - 2).astype(float)])


def _as_utc(value) -> datetime:
    if isinstance(value, str):
        value = datetime.fromisoformat(value)
    return value if value.tzinfo else value.replace(tzinfo=UTC)


def upgrade() -> None:
    op.create_table('telemetry_chunks',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('session_id', sa.Integer(), nullable=False),
    sa.Column('first_seq', sa.Integer(), nullable=False),
    sa.Column('count', sa.Integer(), nullable=False),
    sa.Column('sim_t0', sa.Float(), nullable=False),
    sa.Column('sim_t1', sa.Float(), nullable=False),
    sa.Column('wall_t0', sa.DateTime(timezone=True), nullable=False),
    sa.Column('wall_t1', sa.DateTime(timezone=True), nullable=False),
    sa.Column('data', sa.LargeBinary(), nullable=False),
    sa.ForeignKeyConstraint(['session_id'], ['sessions.id'], ondelete='CASCADE'),
    sa.PrimaryKeyConstraint('id')
    )
    op.create_index('ix_telemetry_chunks_session_time', 'telemetry_chunks', ['session_id', 'sim_t0'], unique=False)
    op.create_table('camera_frames',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('session_id', sa.Integer(), nullable=False),
    sa.Column('seq', sa.Integer(), nullable=False),
    sa.Column('sim_time_s', sa.Float(), nullable=False),
    sa.Column('wall_time', sa.DateTime(timezone=True), nullable=False),
    sa.Column('width', sa.Integer(), nullable=False),
    sa.Column('height', sa.Integer(), nullable=False),
    sa.Column('jpeg', sa.LargeBinary(), nullable=False),
    sa.Column('detections', sa.JSON(), nullable=True),
    sa.ForeignKeyConstraint(['session_id'], ['sessions.id'], ondelete='CASCADE'),
    sa.PrimaryKeyConstraint('id')
    )
    with op.batch_alter_table('camera_frames', schema=None) as batch_op:
        batch_op.create_index(batch_op.f('ix_camera_frames_session_id'), ['session_id'], unique=False)
    with op.batch_alter_table('sessions', schema=None) as batch_op:
        batch_op.add_column(sa.Column('robot_model', sa.String(length=64), nullable=True))
        batch_op.add_column(sa.Column('scene_mjcf', sa.Text(), nullable=True))
        batch_op.add_column(sa.Column('telemetry_layout', sa.JSON(), nullable=True))
        batch_op.add_column(sa.Column('telemetry_hz', sa.Float(), nullable=True))
        batch_op.add_column(sa.Column('heartbeat_at', sa.DateTime(timezone=True), nullable=True))
        batch_op.add_column(sa.Column('recorder_host', sa.String(length=255), nullable=True))
        batch_op.add_column(sa.Column('recorder_pid', sa.Integer(), nullable=True))
    _samples_to_chunks()
    with op.batch_alter_table('state_samples', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_state_samples_session_id'))
    op.drop_table('state_samples')


def _samples_to_chunks() -> None:
    bind = op.get_bind()
    samples = sa.table('state_samples', sa.column('session_id'), sa.column('wall_time'), sa.column('sim_time_s'),
                       sa.column('qpos', sa.JSON()), sa.column('id'))
    chunks = sa.table('telemetry_chunks', sa.column('session_id'), sa.column('first_seq'), sa.column('count'),
                      sa.column('sim_t0'), sa.column('sim_t1'), sa.column('wall_t0'), sa.column('wall_t1'),
                      sa.column('data'))
    sessions = sa.table('sessions', sa.column('id'), sa.column('telemetry_layout', sa.JSON()),
                        sa.column('telemetry_hz'))
    session_ids = [r[0] for r in bind.execute(sa.select(samples.c.session_id).distinct())]
    for sid in session_ids:
        rows = bind.execute(sa.select(samples.c.wall_time, samples.c.sim_time_s, samples.c.qpos)
                            .where(samples.c.session_id == sid).order_by(samples.c.id)).all()
        nq = max(len(r.qpos) for r in rows)
        table = np.full((len(rows), 2 + nq), np.nan)
        walls = [_as_utc(r.wall_time) for r in rows]
        for i, r in enumerate(rows):
            table[i, 0] = r.sim_time_s
            table[i, 1] = walls[i].timestamp()
            table[i, 2:2 + len(r.qpos)] = r.qpos
        for start in range(0, len(rows), _CHUNK_ROWS):
            part = table[start:start + _CHUNK_ROWS]
            bind.execute(chunks.insert().values(
                session_id=sid, first_seq=start, count=len(part), sim_t0=float(part[0, 0]),
                sim_t1=float(part[-1, 0]), wall_t0=walls[start], wall_t1=walls[start + len(part) - 1],
                data=_encode(part)))
        layout = {"fields": [["sim_time_s", 1], ["wall_time_s", 1], ["qpos", nq]], "joint_names": []}
        bind.execute(sessions.update().where(sessions.c.id == sid).values(telemetry_layout=layout, telemetry_hz=10.0))


def downgrade() -> None:
    op.create_table('state_samples',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('session_id', sa.Integer(), nullable=False),
    sa.Column('wall_time', sa.DateTime(timezone=True), nullable=False),
    sa.Column('sim_time_s', sa.Float(), nullable=False),
    sa.Column('mode', sa.String(length=16), nullable=False),
    sa.Column('x', sa.Float(), nullable=False),
    sa.Column('y', sa.Float(), nullable=False),
    sa.Column('z', sa.Float(), nullable=False),
    sa.Column('yaw_rad', sa.Float(), nullable=False),
    sa.Column('tilt_deg', sa.Float(), nullable=False),
    sa.Column('qpos', sa.JSON(), nullable=False),
    sa.ForeignKeyConstraint(['session_id'], ['sessions.id'], ondelete='CASCADE'),
    sa.PrimaryKeyConstraint('id')
    )
    with op.batch_alter_table('state_samples', schema=None) as batch_op:
        batch_op.create_index(batch_op.f('ix_state_samples_session_id'), ['session_id'], unique=False)
    _chunks_to_samples()
    with op.batch_alter_table('sessions', schema=None) as batch_op:
        batch_op.drop_column('recorder_pid')
        batch_op.drop_column('recorder_host')
        batch_op.drop_column('heartbeat_at')
        batch_op.drop_column('telemetry_hz')
        batch_op.drop_column('telemetry_layout')
        batch_op.drop_column('scene_mjcf')
        batch_op.drop_column('robot_model')
    with op.batch_alter_table('camera_frames', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_camera_frames_session_id'))
    op.drop_table('camera_frames')
    op.drop_index('ix_telemetry_chunks_session_time', table_name='telemetry_chunks')
    op.drop_table('telemetry_chunks')


def _chunks_to_samples() -> None:
    """Telemetry back into 10 Hz state samples (the old table kept no more), with the base pose from qpos."""
    bind = op.get_bind()
    sessions = sa.table('sessions', sa.column('id'), sa.column('telemetry_layout', sa.JSON()))
    chunks = sa.table('telemetry_chunks', sa.column('session_id'), sa.column('sim_t0'), sa.column('data'))
    samples = sa.table('state_samples', sa.column('session_id'), sa.column('wall_time'), sa.column('sim_time_s'),
                       sa.column('mode'), sa.column('x'), sa.column('y'), sa.column('z'), sa.column('yaw_rad'),
                       sa.column('tilt_deg'), sa.column('qpos', sa.JSON()))
    for sid, layout in bind.execute(sa.select(sessions.c.id, sessions.c.telemetry_layout)).all():
        if not layout:
            continue
        start = 0
        qpos_at = None
        for name, width in layout["fields"]:
            if name == "qpos":
                qpos_at = slice(start, start + width)
            start += width
        if qpos_at is None:
            continue
        next_t = -math.inf
        for (blob,) in bind.execute(sa.select(chunks.c.data).where(chunks.c.session_id == sid)
                                    .order_by(chunks.c.sim_t0)):
            for row in _decode(blob):
                if row[0] < next_t - 1e-6:
                    continue
                next_t = row[0] + 0.1
                q = row[qpos_at]
                w, x, y, z = q[3:7]
                tilt = math.degrees(math.acos(max(-1.0, min(1.0, 1.0 - 2.0 * (x * x + y * y)))))
                bind.execute(samples.insert().values(
                    session_id=sid, wall_time=datetime.fromtimestamp(row[1], tz=UTC), sim_time_s=float(row[0]),
                    mode="unknown", x=float(q[0]), y=float(q[1]), z=float(q[2]),
                    yaw_rad=math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z)), tilt_deg=tilt,
                    qpos=[float(v) for v in q]))
