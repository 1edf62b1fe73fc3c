"""behaviour runs recorded with the session (issue 37)

Revision ID: 0006
Revises: 0005
Create Date: 2026-11-26 11:30:00
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op


revision = '0006'
down_revision = '0005'
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table('behaviour_runs',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('session_id', sa.Integer(), nullable=False),
    sa.Column('robot_run_id', sa.Integer(), nullable=False),
    sa.Column('robot_command_id', sa.Integer(), nullable=True),
    sa.Column('name', sa.String(length=64), nullable=False),
    sa.Column('params', sa.JSON(), nullable=False),
    sa.Column('source', sa.String(length=16), nullable=False),
    sa.Column('started_at', sa.DateTime(timezone=True), nullable=False),
    sa.Column('sim_start_s', sa.Float(), nullable=False),
    sa.Column('state', sa.String(length=16), nullable=False),
    sa.Column('finished_at', sa.DateTime(timezone=True), nullable=True),
    sa.Column('sim_end_s', sa.Float(), nullable=True),
    sa.Column('reason', sa.Text(), nullable=True),
    sa.Column('feedback', sa.JSON(), nullable=True),
    sa.ForeignKeyConstraint(['session_id'], ['sessions.id'], ondelete='CASCADE'),
    sa.PrimaryKeyConstraint('id')
    )
    with op.batch_alter_table('behaviour_runs', schema=None) as batch_op:
        batch_op.create_index(batch_op.f('ix_behaviour_runs_session_id'), ['session_id'], unique=False)


def downgrade() -> None:
    with op.batch_alter_table('behaviour_runs', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_behaviour_runs_session_id'))
    op.drop_table('behaviour_runs')
