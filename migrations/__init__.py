"""Alembic migrations of the romams database (the schema's owner)."""
