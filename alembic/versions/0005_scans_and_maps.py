"""lidar scans and occupancy maps recorded with the session (for review and the Foxglove export)

Revision ID: 0005
Revises: 0004
Create Date: 2026-11-26 08:00:00
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op


revision = '0005'
down_revision = '0004'
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table('lidar_scans',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('session_id', sa.Integer(), nullable=False),
    sa.Column('sim_time_s', sa.Float(), nullable=False),
    sa.Column('wall_time', sa.DateTime(timezone=True), nullable=False),
    sa.Column('x', sa.Float(), nullable=False),
    sa.Column('y', sa.Float(), nullable=False),
    sa.Column('yaw', sa.Float(), nullable=False),
    sa.Column('height_m', sa.Float(), nullable=False),
    sa.Column('angle_min', sa.Float(), nullable=False),
    sa.Column('angle_increment', sa.Float(), nullable=False),
    sa.Column('range_max', sa.Float(), nullable=False),
    sa.Column('ranges', sa.LargeBinary(), nullable=False),
    sa.ForeignKeyConstraint(['session_id'], ['sessions.id'], ondelete='CASCADE'),
    sa.PrimaryKeyConstraint('id')
    )
    with op.batch_alter_table('lidar_scans', schema=None) as batch_op:
        batch_op.create_index(batch_op.f('ix_lidar_scans_session_id'), ['session_id'], unique=False)
    op.create_table('occupancy_maps',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('session_id', sa.Integer(), nullable=False),
    sa.Column('sim_time_s', sa.Float(), nullable=False),
    sa.Column('wall_time', sa.DateTime(timezone=True), nullable=False),
    sa.Column('resolution', sa.Float(), nullable=False),
    sa.Column('origin_x', sa.Float(), nullable=False),
    sa.Column('origin_y', sa.Float(), nullable=False),
    sa.Column('width', sa.Integer(), nullable=False),
    sa.Column('height', sa.Integer(), nullable=False),
    sa.Column('scans', sa.Integer(), nullable=False),
    sa.Column('data', sa.LargeBinary(), nullable=False),
    sa.ForeignKeyConstraint(['session_id'], ['sessions.id'], ondelete='CASCADE'),
    sa.PrimaryKeyConstraint('id')
    )
    with op.batch_alter_table('occupancy_maps', schema=None) as batch_op:
        batch_op.create_index(batch_op.f('ix_occupancy_maps_session_id'), ['session_id'], unique=False)


def downgrade() -> None:
    with op.batch_alter_table('occupancy_maps', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_occupancy_maps_session_id'))
    op.drop_table('occupancy_maps')
    with op.batch_alter_table('lidar_scans', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_lidar_scans_session_id'))
    op.drop_table('lidar_scans')
