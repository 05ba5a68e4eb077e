"""wing active basis

Revision ID: 0004
Revises: 0003
Create Date: 2026-12-01 17:30:00

Each wing gets an explicit active basis (the one evaluations use unless a request names another).
Existing wings keep answering as before: their newest basis becomes the active one.
"""

from collections.abc import Sequence

import sqlalchemy as sa
from alembic import op


revision: str = '0004'
down_revision: str | None = '0003'
branch_labels: str | Sequence[str] | None = None
depends_on: str | Sequence[str] | None = None


def upgrade() -> None:
    with op.batch_alter_table('wings', schema=None) as batch_op:
        batch_op.add_column(sa.Column('active_basis_id', sa.Integer(), nullable=True))
    op.execute("UPDATE wings SET active_basis_id = (SELECT max(bases.id) FROM bases WHERE bases.wing_id = wings.id)")


def downgrade() -> None:
    with op.batch_alter_table('wings', schema=None) as batch_op:
        batch_op.drop_column('active_basis_id')
