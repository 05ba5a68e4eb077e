"""Upload of external mode shapes: JSON / NPZ file, or a Nastran deck + OP2 (multipart).

The deck (``bdf``) may be one file, several files (main deck and its INCLUDE files) or a zip of them. Form fields
choose what is read from the OP2: ``subcase``, ``modes`` (a count or ids "1,2,4"), ``skip_below_hz`` (rigid-body
modes), ``grids`` (ids "101-140,150" or "planform"), ``units`` and ``wtmass``; ``spline`` how the shapes go onto
a wing's standard mesh.
"""

from __future__ import annotations

import dataclasses
import tempfile
from pathlib import Path
from typing import Any

from fastapi import APIRouter, Depends, File, Form, UploadFile
from fastapi.concurrency import run_in_threadpool

from api.deps import Service, require_key, service
from api.openapi import READ, WRITE
from api.problems import Problem, from_value_error, invalid
from api.responses import ModesStored, ok
from api.uploads import filename, save, save_deck

router = APIRouter(tags=["modes"], responses=READ)


def _nastran_modes(deck: Path, op2: Path, options: dict[str, Any], spline: str) -> Any:
    """ExternalModes of an uploaded deck + OP2 (INCLUDEs confined to the upload)."""
    from romams_core.modes_io import load_modes_nastran
    from romams_core.nastran import NastranOptions

    modes = load_modes_nastran(deck, op2, options=NastranOptions(**options), confine=True)
    return dataclasses.replace(modes, spline=spline)


@router.post("/modes", status_code=201, dependencies=[Depends(require_key)],
             responses={**WRITE, **ok(ModesStored, "the stored modes", 201)})
async def upload_modes(bdf: list[UploadFile] | None = File(default=None), op2: UploadFile | None = File(default=None),
                       file: UploadFile | None = File(default=None),
                       subcase: int | None = Form(default=None, ge=0),
                       modes: str | None = Form(default=None, max_length=2000),
                       skip_below_hz: float | None = Form(default=None, ge=0, allow_inf_nan=False),
                       grids: str | None = Form(default=None, max_length=20000),
                       units: str = Form(default="si", max_length=20), wtmass: float | None = Form(
                           default=None, gt=0, allow_inf_nan=False),
                       spline: str = Form(default="auto", max_length=20),
                       svc: Service = Depends(service)) -> dict[str, Any]:
    """Store external modes: ``bdf`` (one or more files, or a zip) + ``op2`` (Nastran SOL 103 / SOL 145), or
    ``file`` (.json / .npz); -> {"id"}."""
    from romams_core import modes_io

    limit = svc.settings.upload_max_bytes
    options = {"subcase": subcase, "modes": modes, "skip_below_hz": skip_below_hz, "grids": grids, "units": units,
               "wtmass": wtmass}
    with tempfile.TemporaryDirectory(prefix="romams-upload-") as tmp:
        folder = Path(tmp)
        try:
            if bdf or op2 is not None:
                if not bdf or op2 is None:
                    raise invalid("bdf" if not bdf else "op2", "a Nastran upload needs both 'bdf' and 'op2' files")
                (folder / "deck").mkdir()
                deck = await save_deck(bdf, folder / "deck", limit, svc.settings.upload_inflated_max_bytes)
                o = await save(op2, folder / "model.op2", limit, "op2")
                try:
                    got = await run_in_threadpool(_nastran_modes, deck, o, options, spline)
                except ImportError as exc:
                    raise Problem(501, "bdf: Nastran support (pyNastran) is not installed on this server",
                                  "bdf") from exc
                source, name = "nastran", f"{filename(bdf[0])} + {filename(op2)}"
            elif file is not None:
                fname = (file.filename or "").lower()
                if fname.endswith(".json"):
                    got = modes_io.load_modes_json(await save(file, folder / "modes.json", limit, "file"))
                elif fname.endswith(".npz"):  # sizes checked from the zip directory before anything is inflated
                    got = modes_io.load_modes_npz(await save(file, folder / "modes.npz", limit, "file"),
                                                  max_bytes=svc.settings.upload_inflated_max_bytes)
                else:
                    raise invalid("file", "must be a .json or .npz file")
                got = dataclasses.replace(got, spline=spline)
                source, name = fname.rsplit(".", 1)[-1], filename(file)
            else:
                raise invalid("file", "give 'file' (.json/.npz) or both 'bdf' and 'op2'")
        except ValueError as exc:
            nastran_fields = {"subcase", "modes", "n_modes", "skip_below_hz", "grids", "units", "wtmass", "spline",
                              "bdf", "op2"}
            field = getattr(exc, "field", "")
            prefix = "" if field in nastran_fields else ("file" if file is not None else "bdf")
            raise from_value_error(exc, prefix) from exc
    mid = svc.store.modes.save(got, source, name, summary={"n_nodes": int(got.nodes.shape[0]),
                                                          "n_modes": int(got.shapes.shape[1])})
    return {"id": mid, "n_nodes": int(got.nodes.shape[0]), "n_modes": int(got.shapes.shape[1]),
            "frequencies_hz": [float(f) for f in got.frequencies_hz]}
