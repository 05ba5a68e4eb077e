"""Service layer: the use cases shared by the CLI, the API and the workers (evaluation, queue configuration).

Layering: ``api`` and ``worker`` sit above this package and call it; it sits above ``romams_core`` (pure
numerics). It never imports ``api`` or ``worker`` (import-linter contract in pyproject.toml).
"""
