"""MkDocs hook: adds the HTTP API reference page generated from the app's OpenAPI document (api.openapi_doc)."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

from mkdocs.structure.files import File, Files

API_PAGE = "reference/api.md"


def on_files(files: Files, config: Any) -> Files:
    """Add ``reference/api.md``, rendered from ``api.app``'s OpenAPI document of this checkout, to the site."""
    root = str(Path(config.config_file_path).resolve().parent)
    if root not in sys.path:
        sys.path.insert(0, root)
    from api.openapi_doc import openapi_schema, render

    files.append(File.generated(config, API_PAGE, content=render(openapi_schema())))
    return files
