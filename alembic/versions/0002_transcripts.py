"""transcripts: what was heard, with a reference to the recording

Revision ID: 0002
Revises: 0001
Create Date: 2026-11-25 03:35:00
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op


revision = '0002'
down_revision = '0001'
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table('transcripts',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('session_id', sa.Integer(), nullable=False),
    sa.Column('received_at', sa.DateTime(timezone=True), nullable=False),
    sa.Column('source', sa.String(length=16), nullable=False),
    sa.Column('text', sa.Text(), nullable=False),
    sa.Column('confidence', sa.Float(), nullable=False),
    sa.Column('engine', sa.String(length=32), nullable=False),
    sa.Column('in_grammar', sa.Boolean(), nullable=False),
    sa.Column('audio_s', sa.Float(), nullable=False),
    sa.Column('decode_ms', sa.Float(), nullable=False),
    sa.Column('audio_path', sa.String(length=512), nullable=True),
    sa.ForeignKeyConstraint(['session_id'], ['sessions.id'], ondelete='CASCADE'),
    sa.PrimaryKeyConstraint('id')
    )
    with op.batch_alter_table('transcripts', schema=None) as batch_op:
        batch_op.create_index(batch_op.f('ix_transcripts_session_id'), ['session_id'], unique=False)


def downgrade() -> None:
    with op.batch_alter_table('transcripts', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_transcripts_session_id'))
    op.drop_table('transcripts')
