"""runs and their evaluations; job run, traceback and progress events

Revision ID: 0005
Revises: 0004
Create Date: 2026-12-02 09:50:00

A run groups the evaluations of an optimization or UQ campaign; every design of its batches is stored compactly
in ``run_evaluations``. Jobs get the run they belong to, the traceback of a failure and a short progress history.
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op


revision: str = '0005'
down_revision: str | None = '0004'
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    op.create_table(
        'runs',
        sa.Column('id', sa.Integer(), nullable=False),
        sa.Column('name', sa.String(length=200), nullable=False),
        sa.Column('wing_id', sa.Integer(), nullable=True),
        sa.Column('settings', sa.JSON(), nullable=False),
        sa.Column('created_at', sa.DateTime(timezone=True), nullable=False),
        sa.ForeignKeyConstraint(['wing_id'], ['wings.id'], name=op.f('fk_runs_wing_id_wings'), ondelete='SET NULL'),
        sa.PrimaryKeyConstraint('id', name=op.f('pk_runs')),
    )
    op.create_table(
        'run_evaluations',
        sa.Column('id', sa.Integer(), nullable=False),
        sa.Column('run_id', sa.Integer(), nullable=False),
        sa.Column('job_id', sa.String(length=64), nullable=True),
        sa.Column('x', sa.JSON(), nullable=False),
        sa.Column('mass_kg', sa.Float(), nullable=True),
        sa.Column('objective', sa.Float(), nullable=True),
        sa.Column('feasible', sa.Boolean(), nullable=False),
        sa.Column('envelope_ok', sa.Boolean(), nullable=True),
        sa.Column('min_mac', sa.Float(), nullable=True),
        sa.Column('flutter', sa.JSON(), nullable=False),
        sa.Column('error', sa.Text(), nullable=True),
        sa.Column('evaluation_id', sa.Integer(), nullable=True),
        sa.ForeignKeyConstraint(['evaluation_id'], ['evaluations.id'],
                                name=op.f('fk_run_evaluations_evaluation_id_evaluations'), ondelete='SET NULL'),
        sa.ForeignKeyConstraint(['run_id'], ['runs.id'], name=op.f('fk_run_evaluations_run_id_runs'),
                                ondelete='CASCADE'),
        sa.PrimaryKeyConstraint('id', name=op.f('pk_run_evaluations')),
    )
    with op.batch_alter_table('run_evaluations', schema=None) as batch_op:
        batch_op.create_index(batch_op.f('ix_run_evaluations_run_id'), ['run_id'], unique=False)
    with op.batch_alter_table('jobs', schema=None) as batch_op:
        batch_op.add_column(sa.Column('run_id', sa.Integer(), nullable=True))
        batch_op.add_column(sa.Column('traceback', sa.Text(), nullable=True))
        batch_op.add_column(sa.Column('events', sa.JSON(), nullable=True))
        batch_op.create_index(batch_op.f('ix_jobs_run_id'), ['run_id'], unique=False)
        batch_op.create_foreign_key(batch_op.f('fk_jobs_run_id_runs'), 'runs', ['run_id'], ['id'],
                                    ondelete='SET NULL')


def downgrade() -> None:
    with op.batch_alter_table('jobs', schema=None) as batch_op:
        batch_op.drop_constraint(batch_op.f('fk_jobs_run_id_runs'), type_='foreignkey')
        batch_op.drop_index(batch_op.f('ix_jobs_run_id'))
        batch_op.drop_column('events')
        batch_op.drop_column('traceback')
        batch_op.drop_column('run_id')
    with op.batch_alter_table('run_evaluations', schema=None) as batch_op:
        batch_op.drop_index(batch_op.f('ix_run_evaluations_run_id'))
    op.drop_table('run_evaluations')
    op.drop_table('runs')
