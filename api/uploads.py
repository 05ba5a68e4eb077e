"""Uploaded files on disk: bounded copies, and Nastran decks given as several files or a zip (INCLUDE files).

Every file lands in a fresh temporary folder under a cleaned base name; a zip is unpacked there member by member
(regular files only, no absolute or ``..`` names, at most ``MAX_DECK_FILES`` members and
``upload_inflated_max_bytes`` in all, checked from the zip directory and while inflating). Error messages name
the client's file names, never a folder of the server.
"""

from __future__ import annotations

import re
import zipfile
from pathlib import Path, PurePosixPath
from typing import Any

from api.problems import Problem, invalid

MAX_DECK_FILES = 200
_SAFE = re.compile(r"[^A-Za-z0-9._-]+")


def filename(upload: Any) -> str:
    """The client's file name as stored: no NUL character, at most 190 characters (two fit the column)."""
    return (getattr(upload, "filename", "") or "").replace("\x00", "")[:190]


def safe_name(name: str, default: str) -> str:
    """A plain base name for a file on disk (letters, digits, ``._-``), ``default`` when nothing is left."""
    base = _SAFE.sub("_", PurePosixPath(name.replace("\\", "/")).name).strip("._")
    return base[:120] or default


async def save(upload: Any, path: Path, limit: int, field: str) -> Path:
    """Copy an upload to ``path`` in 1 MiB pieces (413 naming ``field`` past ``limit`` bytes)."""
    size = 0
    with open(path, "wb") as out:
        while piece := await upload.read(1 << 20):
            size += len(piece)
            if size > limit:
                raise Problem(413, f"{field}: larger than {limit} bytes (upload_max_bytes)", field)
            out.write(piece)
    return path


def _unzip(archive: Path, folder: Path, inflated_max: int, field: str) -> None:
    """Unpack a zip of deck files into ``folder`` (flat names kept relative; bounded count and size)."""
    try:
        with zipfile.ZipFile(archive) as zf:
            infos = [i for i in zf.infolist() if not i.is_dir()]
            if len(infos) > MAX_DECK_FILES:
                raise invalid(field, f"the zip holds {len(infos)} files (at most {MAX_DECK_FILES})")
            if sum(i.file_size for i in infos) > inflated_max:
                raise Problem(413, f"{field}: the zip inflates past {inflated_max} bytes "
                                   "(upload_inflated_max_bytes)", field)
            for info in infos:
                parts = PurePosixPath(info.filename.replace("\\", "/")).parts
                if not parts or info.filename.startswith(("/", "\\")) or ".." in parts or ":" in info.filename:
                    raise invalid(field, f"zip member {PurePosixPath(info.filename).name!r}: names must be "
                                         "relative, inside the archive")
                if (info.external_attr >> 16) & 0o170000 == 0o120000:
                    raise invalid(field, f"zip member {parts[-1]!r} is a link; only plain files are read")
                target = folder.joinpath(*[safe_name(p, "_") for p in parts])
                target.parent.mkdir(parents=True, exist_ok=True)
                with zf.open(info) as src, open(target, "wb") as out:
                    written = 0
                    while piece := src.read(1 << 20):
                        written += len(piece)
                        if written > info.file_size:
                            raise invalid(field, f"zip member {parts[-1]!r} inflates past its declared size")
                        out.write(piece)
    except (zipfile.BadZipFile, zipfile.LargeZipFile, OSError, EOFError, NotImplementedError) as exc:
        raise invalid(field, f"not a readable zip archive ({type(exc).__name__})") from None
    archive.unlink()


async def save_deck(uploads: list[Any], folder: Path, limit: int, inflated_max: int, field: str = "bdf") -> Path:
    """Save a deck given as one or several files or one zip into ``folder``; returns the main deck's path."""
    from romams_core.nastran import main_deck

    if not uploads:
        raise invalid(field, "give the Nastran deck: one file, several (main deck and INCLUDE files), or a zip")
    if len(uploads) > MAX_DECK_FILES:
        raise invalid(field, f"{len(uploads)} files (at most {MAX_DECK_FILES})")
    for i, upload in enumerate(uploads):
        if not hasattr(upload, "read"):
            raise invalid(field, "must be a file upload (multipart/form-data)")
        name = safe_name(filename(upload), f"deck{i}.bdf")
        path = await save(upload, folder / name, limit, field)
        if zipfile.is_zipfile(path):
            _unzip(path, folder, inflated_max, field)
    return main_deck(folder)
