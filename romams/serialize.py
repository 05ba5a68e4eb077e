"""Generic (dataclass | value) <-> (JSON meta, compressed NPZ bytes) serializer for core results.

Every numpy array in the object tree goes into one ``np.savez_compressed`` archive under a path-like
key; the JSON meta holds everything else and, in place of each array, ``{"__ndarray__": key, "shape",
"dtype"}``. Nested dataclasses, tuples, lists, dicts (string keys), complex and non-finite floats are
tagged so that :func:`loads` rebuilds the same tree. Classes that define both ``to_dict`` and
``from_dict`` are stored through them. Arrays are loaded with ``allow_pickle=False``; object arrays
are refused. Classes are only re-imported from this project's packages.
"""

from __future__ import annotations

import dataclasses
import importlib
import io
import math
import sys
from collections.abc import Mapping
from typing import Any

import numpy as np

ALLOWED_PREFIXES = ("romams_core", "romams", "worker", "api", "client", "tests")
FORMAT = 1


_REGISTRY: dict[str, type] = {}

#: Stored type names of classes that have moved since rows were written: old 'module:QualName' -> new one.
#: Stored rows keep loading after a refactoring (the flutter module became a package in issue 9).
ALIASES: dict[str, str] = {
    "romams_core.flutter:FlutterResult": "romams_core.flutter.result:FlutterResult",
}


def register(cls: type) -> type:
    """Allow ``cls`` (defined outside this project's packages) to be rebuilt by :func:`loads`; usable as decorator."""
    _REGISTRY[type_name(cls)] = cls
    return cls


def type_name(cls: type) -> str:
    """'module:QualName' of a class."""
    return f"{cls.__module__}:{cls.__qualname__}"


def resolve(name: str, types: Mapping[str, type] | None = None) -> type:
    """Class from 'module:QualName', restricted to this project's packages (or ``types``)."""
    if types and name in types:
        return types[name]
    if name in _REGISTRY:
        return _REGISTRY[name]
    name = ALIASES.get(name, name)
    module, _, qual = name.partition(":")
    if module.split(".")[0] not in ALLOWED_PREFIXES:
        raise ValueError(f"serialized type {name!r}: module not allowed")
    mod = sys.modules.get(module) or importlib.import_module(module)
    obj: Any = mod
    for part in qual.split("."):
        obj = getattr(obj, part)
    if not isinstance(obj, type):
        raise ValueError(f"serialized type {name!r}: not a class")
    return obj


def _encode_float(x: float) -> Any:
    """JSON-safe float (non-finite values tagged, since PostgreSQL JSON refuses NaN)."""
    return x if math.isfinite(x) else {"__float__": repr(x)}


def _encode(value: Any, key: str, arrays: dict[str, np.ndarray]) -> Any:
    """Encode ``value`` into JSON-able data, moving arrays into ``arrays`` under ``key``."""
    if value is None or isinstance(value, bool | str):
        return value
    if isinstance(value, np.ndarray):
        if value.dtype.hasobject:
            raise ValueError(f"{key or 'value'}: object arrays cannot be serialized")
        k = key or "value"
        arrays[k] = value
        return {"__ndarray__": k, "shape": list(value.shape), "dtype": value.dtype.str}
    if isinstance(value, np.generic):
        return _encode(value.item(), key, arrays)
    if isinstance(value, int):
        return value
    if isinstance(value, float):
        return _encode_float(value)
    if isinstance(value, complex):
        return {"__complex__": [_encode_float(value.real), _encode_float(value.imag)]}
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        cls = type(value)
        if callable(getattr(cls, "from_dict", None)) and callable(getattr(value, "to_dict", None)):
            return {"__todict__": type_name(cls), "data": _encode(value.to_dict(), key, arrays)}
        fields = {f.name: _encode(getattr(value, f.name), f"{key}.{f.name}" if key else f.name, arrays)
                  for f in dataclasses.fields(value)}
        return {"__dataclass__": type_name(cls), "fields": fields}
    if isinstance(value, tuple):
        return {"__tuple__": [_encode(v, f"{key}[{i}]", arrays) for i, v in enumerate(value)]}
    if isinstance(value, list):
        return [_encode(v, f"{key}[{i}]", arrays) for i, v in enumerate(value)]
    if isinstance(value, Mapping):
        out = {}
        for k, v in value.items():
            if not isinstance(k, str):
                raise ValueError(f"{key or 'value'}: dict keys must be strings, got {k!r}")
            out[k] = _encode(v, f"{key}/{k}" if key else k, arrays)
        return {"__dict__": out}
    raise ValueError(f"{key or 'value'}: cannot serialize a {type(value).__name__}")


def _decode(data: Any, arrays: Mapping[str, np.ndarray], types: Mapping[str, type] | None) -> Any:
    """Inverse of :func:`_encode`."""
    if isinstance(data, list):
        return [_decode(v, arrays, types) for v in data]
    if not isinstance(data, dict):
        return data
    if "__ndarray__" in data:
        arr = arrays[data["__ndarray__"]]
        if list(arr.shape) != list(data["shape"]):
            raise ValueError(f"array {data['__ndarray__']!r}: shape {arr.shape} does not match meta {data['shape']}")
        return arr
    if "__float__" in data:
        return float(data["__float__"])
    if "__complex__" in data:
        re, im = (_decode(v, arrays, types) for v in data["__complex__"])
        return complex(re, im)
    if "__tuple__" in data:
        return tuple(_decode(v, arrays, types) for v in data["__tuple__"])
    if "__dict__" in data:
        return {k: _decode(v, arrays, types) for k, v in data["__dict__"].items()}
    if "__todict__" in data:
        return resolve(data["__todict__"], types).from_dict(_decode(data["data"], arrays, types))
    if "__dataclass__" in data:
        cls = resolve(data["__dataclass__"], types)
        if not dataclasses.is_dataclass(cls):
            raise ValueError(f"serialized type {data['__dataclass__']!r}: not a dataclass")
        values = {k: _decode(v, arrays, types) for k, v in data["fields"].items()}
        fields = {f.name: f for f in dataclasses.fields(cls)}
        obj = cls(**{k: v for k, v in values.items() if k in fields and fields[k].init})
        for k, v in values.items():
            if k in fields and not fields[k].init:
                object.__setattr__(obj, k, v)
        return obj
    raise ValueError(f"unrecognized serialized node with keys {sorted(data)}")


def dumps(obj: Any) -> tuple[dict[str, Any], bytes]:
    """Serialize ``obj`` to (JSON-able meta, compressed NPZ bytes)."""
    arrays: dict[str, np.ndarray] = {}
    tree = _encode(obj, "", arrays)
    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    return {"format": FORMAT, "tree": tree}, buf.getvalue()


def loads(meta: Mapping[str, Any], blob: bytes, types: Mapping[str, type] | None = None) -> Any:
    """Rebuild the object stored by :func:`dumps` (``types`` maps 'module:Qual' names to classes)."""
    if meta.get("format") != FORMAT:
        raise ValueError(f"meta.format: unsupported serializer format {meta.get('format')!r}")
    with np.load(io.BytesIO(blob), allow_pickle=False) as npz:
        arrays = {k: npz[k] for k in npz.files}
    return _decode(meta["tree"], arrays, types)


def to_jsonable(obj: Any) -> Any:
    """Plain JSON view of a result tree: arrays become nested lists, non-finite floats None (for the API)."""
    if obj is None or isinstance(obj, bool | str | int):
        return obj
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, np.ndarray):
        if np.iscomplexobj(obj):
            return {"real": to_jsonable(obj.real), "imag": to_jsonable(obj.imag)}
        if obj.dtype.kind == "f":
            return [to_jsonable(v) for v in obj.tolist()] if obj.ndim else to_jsonable(float(obj))
        return obj.tolist()
    if isinstance(obj, np.generic):
        return to_jsonable(obj.item())
    if isinstance(obj, complex):
        return {"real": to_jsonable(obj.real), "imag": to_jsonable(obj.imag)}
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {f.name: to_jsonable(getattr(obj, f.name)) for f in dataclasses.fields(obj)}
    if isinstance(obj, Mapping):
        return {str(k): to_jsonable(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [to_jsonable(v) for v in obj]
    return str(obj)
