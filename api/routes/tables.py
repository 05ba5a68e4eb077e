"""Imported aerodynamic models: a GAF table uploaded for a wing's basis becomes the ROM of solver
"external:<label>" (``romams.services.gaf_import``, the use case of ``romams train --gaf``)."""

from __future__ import annotations

import io
from typing import Any

import numpy as np
from fastapi import APIRouter, Depends, Request, Response
from fastapi.concurrency import run_in_threadpool

from api.deps import Service, no_nul, require_key, service, wing_or_404
from api.openapi import FOUND, READ, WING, WRITE, problems
from api.problems import invalid
from api.responses import RomOut, ok
from api.routes.wings import _basis_or_404, _basis_wing
from romams.services.gaf_import import MAX_TABLE_BYTES, import_table, parse_table
from romams.services.models import resolve_basis_id

router = APIRouter(tags=["wings"], responses=READ)

#: the text fields of a table upload (besides the file ``file``)
TABLE_FIELDS = ("label", "mach", "basis_id", "n_lags")
TABLE_BODY = {"requestBody": {"required": True, "content": {"multipart/form-data": {"schema": {
    "type": "object", "required": ["file", "label"], "additionalProperties": False,
    "description": "a GAF table computed on the basis shapes (in the basis' order): NPZ with k, gaf_real, gaf_imag "
                   "[nk, m, m] (m^3 per unit generalized displacement, k on the semichord) and mach; or CSV with the "
                   "header k,row,col,real,imag (then mach is required)",
    "properties": {
        "file": {"type": "string", "format": "binary"},
        "label": {"type": "string", "pattern": "^[A-Za-z0-9_.-]{1,40}$",
                  "description": "the table's name: its ROM's solver is external:<label>"},
        "mach": {"type": "number", "minimum": 0, "exclusiveMaximum": 1,
                 "description": "the Mach number (required for a CSV table; an NPZ table carries its own)"},
        "basis_id": {"type": "integer", "minimum": 1, "description": "the basis (default: the wing's active one)"},
        "n_lags": {"type": "integer", "minimum": 0, "maximum": 12,
                   "description": "RFA lag roots (default: automatic, as for the DLM)"}}}}}}}


def _int_field(text: dict[str, str], key: str, lo: int, hi: int) -> int | None:
    """An optional integer text field in [lo, hi] (422 naming it otherwise)."""
    if not text.get(key):
        return None
    if not text[key].isdigit() or not lo <= int(text[key]) <= hi:
        raise invalid(key, f"must be an integer in [{lo}, {hi}], got {text[key][:20]!r}")
    return int(text[key])


async def _read_form(request: Request) -> tuple[bytes, str, dict[str, str]]:
    """(file bytes, file name, text fields) of the multipart upload (422 naming the field otherwise)."""
    if not request.headers.get("content-type", "").lower().startswith("multipart/form-data"):
        raise invalid("file", "send the table as multipart/form-data (fields file, label, mach, basis_id)")
    form = await request.form(max_files=1, max_fields=len(TABLE_FIELDS))
    try:
        upload = form.get("file")
        if upload is None or isinstance(upload, str):
            raise invalid("file", "missing: the table file (NPZ or CSV)")
        text = {k: v for k, v in form.multi_items() if k != "file"}
        unknown = sorted(set(text) - set(TABLE_FIELDS))
        if unknown:
            raise invalid(unknown[0], f"not a field of a table upload; allowed: file, {', '.join(TABLE_FIELDS)}")
        if any(not isinstance(v, str) for v in text.values()):
            raise invalid(next(k for k, v in text.items() if not isinstance(v, str)), "must be a text field")
        data = await upload.read(MAX_TABLE_BYTES + 1)
        return data, str(upload.filename or ""), {k: str(v) for k, v in text.items()}
    finally:
        await form.close()


NPZ = {200: {"description": "NPZ file: x, y (standard-mesh nodes, m, n_nodes), shapes [n_nodes, m] (out-of-plane "
                              "displacement, m), c_ref (m), basis_id", "content": {"application/octet-stream": {
                                  "schema": {"type": "string", "format": "binary"}}}}}


@router.get("/bases/{basis_id}/shapes.npz", response_class=Response, responses={**FOUND, **NPZ})
def basis_shapes_npz(basis_id: int, svc: Service = Depends(service)) -> Response:
    """The basis shapes as arrays, for a GAF table computed elsewhere: the standard-mesh nodes x, y (m), the
    shapes [n_nodes, m] (out-of-plane displacement, m, +z up) in the basis' order, c_ref (m)."""
    from romams_core.mesh import standard_mesh

    basis = _basis_or_404(svc, basis_id)
    mesh = standard_mesh(_basis_wing(svc, basis_id).planform)
    buf = io.BytesIO()
    np.savez(buf, x=mesh.x, y=mesh.y, shapes=basis.shapes, c_ref=np.float64(mesh.c_ref), basis_id=np.int64(basis_id))
    return Response(buf.getvalue(), media_type="application/octet-stream",
                    headers={"Content-Disposition": f'attachment; filename="basis_{basis_id}_shapes.npz"'})


@router.post("/wings/{wing}/roms/gaf", status_code=201, dependencies=[Depends(require_key)],
             responses={**WRITE, **WING, **problems(409, 413), **ok(RomOut, "the ROM fitted to the table", 201)},
             openapi_extra=TABLE_BODY)
async def import_gaf_table(wing: str, request: Request, svc: Service = Depends(service)) -> dict[str, Any]:
    """Import a GAF table (your CFD's or doublet lattice's forces on the basis shapes) as the ROM of solver
    ``external:<label>`` at its Mach number: fitted by the DLM's rational function approximation, replacing an
    earlier table of that label and Mach; flutter requests use it with ``"solver": "external:<label>"``."""
    wid, wdef = wing_or_404(svc, wing)
    data, filename, text = await _read_form(request)
    no_nul(text, "form")
    if "label" not in text:
        raise invalid("label", "missing: the table's name (its ROM's solver is external:<label>)")
    mach = None
    if text.get("mach"):
        try:
            mach = float(text["mach"])
        except ValueError:
            raise invalid("mach", f"must be a number, got {text['mach'][:20]!r}") from None
        if not 0.0 <= mach < 1.0:
            raise invalid("mach", f"must be in [0, 1), got {mach}")
    basis_id = resolve_basis_id(svc.store, wid, _int_field(text, "basis_id", 1, 2**53))
    n_lags = _int_field(text, "n_lags", 0, 12)
    table = parse_table(data, filename, mach)
    basis = svc.store.bases.load(basis_id)
    fit = {} if n_lags is None else {"n_lags": n_lags}
    rom_id, _ = await run_in_threadpool(import_table, svc.store, wid, wdef, basis_id, basis, table, text["label"],
                                        **fit)
    return next(r for r in svc.store.roms.of_wing(wid, basis_id) if r["id"] == rom_id)
