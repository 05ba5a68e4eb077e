"""How values become rows: content keys, small JSON summaries, wing JSON and timestamps."""

from __future__ import annotations

import dataclasses
import hashlib
import json
from collections.abc import Mapping
from typing import Any

import numpy as np

from romams import serialize


def canonical_json(obj: Any) -> str:
    """Deterministic JSON text (sorted keys, no spaces) of JSON-able data, used for content keys."""
    return json.dumps(serialize.to_jsonable(obj), sort_keys=True, separators=(",", ":"))


def content_hash(*parts: Any) -> str:
    """SHA-256 hex digest of the canonical JSON of ``parts``."""
    return hashlib.sha256(canonical_json(list(parts)).encode()).hexdigest()


def rom_key(wing_id: int, basis_id: int, mach: float, params: Mapping[str, Any]) -> str:
    """Identity of a trained ROM: wing, basis, Mach (to 1e-6) and the solver/identification settings."""
    return content_hash("rom", int(wing_id), int(basis_id), round(float(mach), 6), dict(params))


def small_summary(obj: Any, max_size: int = 256) -> dict[str, Any]:
    """JSON summary of a result dataclass: scalars, strings and arrays with at most ``max_size`` entries, updated with
    the object's own ``summary()`` when it has one."""
    out: dict[str, Any] = {}
    if not dataclasses.is_dataclass(obj):
        return out
    for f in dataclasses.fields(obj):
        v = getattr(obj, f.name)
        if isinstance(v, np.ndarray):
            if v.size <= max_size and v.dtype.kind in "biuf":
                out[f.name] = serialize.to_jsonable(v)
        elif isinstance(v, bool | int | float | str | np.generic) or v is None:
            out[f.name] = serialize.to_jsonable(v)
        elif isinstance(v, list | tuple) and len(v) <= max_size and all(isinstance(x, int | float | str) for x in v):
            out[f.name] = serialize.to_jsonable(list(v))
    summary = getattr(obj, "summary", None)
    if callable(summary):  # the object's own summary (e.g. a ROM's kind, fit error, state count) completes it
        out.update(serialize.to_jsonable(summary()))
    return out


def wing_to_json(wing: Any) -> dict[str, Any]:
    """JSON of a WingDefinition (its to_dict) or, generically, of any dataclass without arrays."""
    if hasattr(wing, "to_dict"):
        return {"format": "to-dict", "type": serialize.type_name(type(wing)),
                "data": serialize.to_jsonable(wing.to_dict())}
    meta, _ = serialize.dumps(wing)
    if '"__ndarray__"' in json.dumps(meta):
        raise ValueError("wing: a definition without to_dict() must not hold arrays")
    return {"format": "serialized", "meta": meta}


def wing_from_json(d: Mapping[str, Any]) -> Any:
    """Inverse of :func:`wing_to_json`."""
    if d.get("format") == "to-dict":
        return serialize.resolve(d["type"]).from_dict(d["data"])
    return serialize.loads(d["meta"], serialize.dumps(None)[1])


def iso(t: Any) -> str | None:
    """ISO-8601 UTC text of a datetime (SQLite returns naive UTC values)."""
    if t is None:
        return None
    if t.tzinfo is None:
        return t.isoformat() + "Z"
    return t.isoformat().replace("+00:00", "Z")
