"""``python -m romams.persistence upgrade``: bring the configured database to Alembic head."""

from __future__ import annotations

import sys
from collections.abc import Sequence

from romams.persistence.engine import head_revision, upgrade
from romams.settings import get_settings


def main(argv: Sequence[str] | None = None) -> None:
    """Run the one command (``upgrade``)."""
    args = list(sys.argv[1:] if argv is None else argv)
    if args != ["upgrade"]:
        raise SystemExit("usage: python -m romams.persistence upgrade")
    upgrade(get_settings().db_url)
    print(f"database at revision {head_revision()}")


if __name__ == "__main__":
    main()
