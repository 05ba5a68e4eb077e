"""Upload of external mode shapes: JSON / NPZ file, or a Nastran BDF + OP2 pair (multipart)."""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

from fastapi import APIRouter, Depends, File, UploadFile

from api.deps import Service, require_key, service
from api.openapi import READ, WRITE
from api.problems import Problem, from_value_error, invalid

router = APIRouter(tags=["modes"], responses=READ)


async def _save(upload: UploadFile, folder: Path, name: str, limit: int, field: str) -> Path:
    """Copy an upload to ``folder/name`` in 1 MiB pieces (413 naming ``field`` past ``limit`` bytes)."""
    path = folder / name
    size = 0
    with open(path, "wb") as out:
        while piece := await upload.read(1 << 20):
            size += len(piece)
            if size > limit:
                raise Problem(413, f"{field}: larger than {limit} bytes (upload_max_bytes)", field)
            out.write(piece)
    return path


def _filename(upload: UploadFile) -> str:
    """The client's file name as stored: no NUL character, at most 190 characters (two fit the column)."""
    return (upload.filename or "").replace("\x00", "")[:190]


@router.post("/modes", status_code=201, dependencies=[Depends(require_key)], responses=WRITE)
async def upload_modes(bdf: UploadFile | None = File(default=None), op2: UploadFile | None = File(default=None),
                       file: UploadFile | None = File(default=None),
                       svc: Service = Depends(service)) -> dict[str, Any]:
    """Store external modes: fields ``bdf`` + ``op2`` (Nastran SOL 103) or ``file`` (.json / .npz); -> {"id"}."""
    from romams_core import modes_io

    limit = svc.settings.upload_max_bytes
    with tempfile.TemporaryDirectory(prefix="romams-upload-") as tmp:
        folder = Path(tmp)
        try:
            if bdf is not None or op2 is not None:
                if bdf is None or op2 is None:
                    raise invalid("bdf" if bdf is None else "op2", "a Nastran upload needs both 'bdf' and 'op2' files")
                b = await _save(bdf, folder, "model.bdf", limit, "bdf")
                o = await _save(op2, folder, "model.op2", limit, "op2")
                try:
                    modes = modes_io.load_modes_nastran(b, o)
                except ImportError as exc:
                    raise Problem(501, "bdf: Nastran support (pyNastran) is not installed on this server",
                                  "bdf") from exc
                except ValueError:
                    raise
                except Exception as exc:  # noqa: BLE001 - pyNastran's own errors on unreadable files
                    raise invalid("bdf", f"could not read the BDF/OP2 pair ({type(exc).__name__}: {exc})") from exc
                source, name = "nastran", f"{_filename(bdf)} + {_filename(op2)}"
            elif file is not None:
                fname = (file.filename or "").lower()
                if fname.endswith(".json"):
                    modes = modes_io.load_modes_json(await _save(file, folder, "modes.json", limit, "file"))
                elif fname.endswith(".npz"):  # sizes checked from the zip directory before anything is inflated
                    modes = modes_io.load_modes_npz(await _save(file, folder, "modes.npz", limit, "file"),
                                                    max_bytes=svc.settings.upload_inflated_max_bytes)
                else:
                    raise invalid("file", "must be a .json or .npz file")
                source, name = fname.rsplit(".", 1)[-1], _filename(file)
            else:
                raise invalid("file", "give 'file' (.json/.npz) or both 'bdf' and 'op2'")
        except ValueError as exc:
            raise from_value_error(exc, "file" if file is not None else "bdf") from exc
    mid = svc.store.modes.save(modes, source, name, summary={"n_nodes": int(modes.nodes.shape[0]),
                                                            "n_modes": int(modes.shapes.shape[1])})
    return {"id": mid, "n_nodes": int(modes.nodes.shape[0]), "n_modes": int(modes.shapes.shape[1]),
            "frequencies_hz": [float(f) for f in modes.frequencies_hz]}
