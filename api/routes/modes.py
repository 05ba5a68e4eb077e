"""Upload of external mode shapes: JSON / NPZ file, or a Nastran BDF + OP2 pair (multipart)."""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

from fastapi import APIRouter, Depends, File, UploadFile

from api.deps import Service, require_key, service
from api.problems import Problem, from_value_error, invalid

router = APIRouter(tags=["modes"])


async def _save(upload: UploadFile, folder: Path, name: str, limit: int) -> Path:
    """Copy an upload to ``folder/name`` (413 over ``limit`` bytes)."""
    data = await upload.read(limit + 1)
    if len(data) > limit:
        raise Problem(413, f"{name}: larger than {limit} bytes", name)
    path = folder / name
    path.write_bytes(data)
    return path


@router.post("/modes", status_code=201, dependencies=[Depends(require_key)])
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
                b = await _save(bdf, folder, "model.bdf", limit)
                o = await _save(op2, folder, "model.op2", limit)
                try:
                    modes = modes_io.load_modes_nastran(b, o)
                except ImportError as exc:
                    raise Problem(501, "bdf: Nastran support (pyNastran) is not installed on this server",
                                  "bdf") from exc
                except ValueError:
                    raise
                except Exception as exc:  # noqa: BLE001 - pyNastran's own errors on unreadable files
                    raise invalid("bdf", f"could not read the BDF/OP2 pair ({type(exc).__name__}: {exc})") from exc
                source, name = "nastran", f"{bdf.filename} + {op2.filename}"
            elif file is not None:
                fname = (file.filename or "").lower()
                if fname.endswith(".json"):
                    modes = modes_io.load_modes_json(await _save(file, folder, "modes.json", limit))
                elif fname.endswith(".npz"):
                    modes = modes_io.load_modes_npz(await _save(file, folder, "modes.npz", limit))
                else:
                    raise invalid("file", "must be a .json or .npz file")
                source, name = fname.rsplit(".", 1)[-1], file.filename or ""
            else:
                raise invalid("file", "give 'file' (.json/.npz) or both 'bdf' and 'op2'")
        except ValueError as exc:
            raise from_value_error(exc, "file" if file is not None else "bdf") from exc
    mid = svc.store.modes.save(modes, source, name, summary={"n_nodes": int(modes.nodes.shape[0]),
                                                            "n_modes": int(modes.shapes.shape[1])})
    return {"id": mid, "n_nodes": int(modes.nodes.shape[0]), "n_modes": int(modes.shapes.shape[1]),
            "frequencies_hz": [float(f) for f in modes.frequencies_hz]}
