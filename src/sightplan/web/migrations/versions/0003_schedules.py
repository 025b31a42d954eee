"""Schedules linked to models (the 4D date slider and evaluations at a capture date); jobs that link them.

Revision ID: 0003
Revises: 0002
Create Date: 2026-11-22
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = '0003'
down_revision = '0002'
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table('schedules',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('project_id', sa.Integer(), nullable=False),
    sa.Column('model_id', sa.Integer(), nullable=False),
    sa.Column('original_name', sa.String(length=255), nullable=False),
    sa.Column('stored_name', sa.String(length=64), nullable=True),
    sa.Column('rules_name', sa.String(length=64), nullable=True),
    sa.Column('prefer_actual', sa.Boolean(), nullable=False),
    sa.Column('dates_name', sa.String(length=64), nullable=False),
    sa.Column('status', sa.String(length=16), nullable=False),
    sa.Column('error', sa.Text(), nullable=True),
    sa.Column('report', sa.JSON(), nullable=True),
    sa.Column('first_date', sa.String(length=10), nullable=True),
    sa.Column('last_date', sa.String(length=10), nullable=True),
    sa.Column('created_at', sa.DateTime(timezone=True), nullable=False),
    sa.ForeignKeyConstraint(['project_id'], ['projects.id'], ondelete='CASCADE'),
    sa.ForeignKeyConstraint(['model_id'], ['models.id'], ondelete='CASCADE'),
    sa.PrimaryKeyConstraint('id'),
    sa.UniqueConstraint('dates_name')
    )
    op.create_index('ix_schedules_project_id', 'schedules', ['project_id'])
    op.create_index('ix_schedules_model_id', 'schedules', ['model_id'])
    with op.batch_alter_table('jobs') as batch:
        batch.add_column(sa.Column('schedule_id', sa.Integer(), nullable=True))
        batch.create_foreign_key('fk_jobs_schedule_id', 'schedules', ['schedule_id'], ['id'], ondelete='CASCADE')


def downgrade() -> None:
    with op.batch_alter_table('jobs') as batch:
        batch.drop_constraint('fk_jobs_schedule_id', type_='foreignkey')
        batch.drop_column('schedule_id')
    op.drop_index('ix_schedules_model_id', table_name='schedules')
    op.drop_index('ix_schedules_project_id', table_name='schedules')
    op.drop_table('schedules')
