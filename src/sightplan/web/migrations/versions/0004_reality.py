"""Reality captures (point clouds as 3D Tiles, meshes as GLB) for the viewer and as occluders; jobs that prepare them.

Revision ID: 0004
Revises: 0003
Create Date: 2026-11-22
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = '0004'
down_revision = '0003'
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table('reality',
    sa.Column('id', sa.Integer(), nullable=False),
    sa.Column('project_id', sa.Integer(), nullable=False),
    sa.Column('original_name', sa.String(length=255), nullable=False),
    sa.Column('stored_name', sa.String(length=64), nullable=False),
    sa.Column('view_name', sa.String(length=64), nullable=False),
    sa.Column('kind', sa.String(length=16), nullable=False),
    sa.Column('size_bytes', sa.Integer(), nullable=False),
    sa.Column('status', sa.String(length=16), nullable=False),
    sa.Column('error', sa.Text(), nullable=True),
    sa.Column('points', sa.Integer(), nullable=True),
    sa.Column('triangles', sa.Integer(), nullable=True),
    sa.Column('bounds', sa.JSON(), nullable=True),
    sa.Column('created_at', sa.DateTime(timezone=True), nullable=False),
    sa.ForeignKeyConstraint(['project_id'], ['projects.id'], ondelete='CASCADE'),
    sa.PrimaryKeyConstraint('id'),
    sa.UniqueConstraint('stored_name'),
    sa.UniqueConstraint('view_name')
    )
    op.create_index('ix_reality_project_id', 'reality', ['project_id'])
    with op.batch_alter_table('jobs') as batch:
        batch.add_column(sa.Column('reality_id', sa.Integer(), nullable=True))
        batch.create_foreign_key('fk_jobs_reality_id', 'reality', ['reality_id'], ['id'], ondelete='CASCADE')


def downgrade() -> None:
    with op.batch_alter_table('jobs') as batch:
        batch.drop_constraint('fk_jobs_reality_id', type_='foreignkey')
        batch.drop_column('reality_id')
    op.drop_index('ix_reality_project_id', table_name='reality')
    op.drop_table('reality')
