"""Wing definitions from files: a JSON definition or a Nastran deck (CAERO1 planform), and their JSON Schema.

Used wherever a wing is named (``--wing NAME|ID|FILE.json|FILE.bdf`` in the CLI) and by the API's wing import.
A wing read from a file is stored under its name; a different definition already stored under that name is a
conflict (rename the file's wing), never silently replaced or reused.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from romams_core.errors import InputError
from romams_core.wing import WingDefinition

#: suffixes of Nastran bulk-data decks
DECK_SUFFIXES = (".bdf", ".dat", ".nas", ".blk", ".bulk")
WING_FILE_SUFFIXES = (".json", *DECK_SUFFIXES)


def is_wing_file(name: str) -> bool:
    """True when ``name`` is an existing file with a wing suffix (.json or a Nastran deck)."""
    path = Path(name)
    return path.suffix.lower() in WING_FILE_SUFFIXES and path.is_file()


def load_wing_file(path: str | Path, *, name: str | None = None, units: str = "si", symmetry: str | None = None,
                   n_chord: int | None = None, n_span: int | None = None, confine: bool = False) -> WingDefinition:
    """WingDefinition of a JSON file (``WingDefinition.to_dict``, or ``{"definition": ...}``) or of a deck's
    CAERO1 / AERO(S) cards (planform only); InputError naming the bad field."""
    path = Path(path)
    if path.suffix.lower() == ".json":
        try:
            data = json.loads(path.read_text())
        except (json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise InputError("wing", f"{path.name} is not valid JSON ({exc})") from None
        if isinstance(data, dict) and isinstance(data.get("definition"), dict):
            data = data["definition"]
        wing = WingDefinition.from_dict(data)
        return wing if name is None else WingDefinition.from_dict({**wing.to_dict(), "name": name})
    from romams_core.nastran import wing_from_bdf

    return wing_from_bdf(path, name, units=units, symmetry=symmetry, n_chord=n_chord, n_span=n_span,
                         confine=confine)


def store_wing(store: Any, wing: WingDefinition) -> int:
    """Id of ``wing`` in the store: created, or the stored one of that name when it is the same definition."""
    found = store.wings.find(wing.name)
    if found is None:
        return int(store.wings.ensure(wing))
    if found[1].to_dict() != wing.to_dict():
        raise InputError("name", f"a different wing named {wing.name!r} is already stored (id {found[0]}); give "
                                 "the file's wing another name")
    return int(found[0])


def wing_schema() -> dict[str, Any]:
    """JSON Schema (2020-12) of a wing definition, generated from the WingDefinition dataclasses."""
    from pydantic import TypeAdapter

    schema = TypeAdapter(WingDefinition).json_schema(mode="serialization")
    defs = schema.get("$defs", {})
    for cls, kind in (("PlateStructure", "plate"), ("BeamStructure", "beam")):
        if cls in defs and "kind" in defs[cls].get("properties", {}):
            defs[cls]["properties"]["kind"] = {"const": kind, "title": "Kind", "default": kind}
            defs[cls].setdefault("required", []).append("kind")
    props = schema.get("properties", {})
    if "symmetry" in props:
        props["symmetry"]["enum"] = ["symmetric", "antisymmetric", "none"]
        props["symmetry"]["description"] = ("symmetry about the root plane: the DLM, the UVLM and the TSD "
                                            "model all three")
    kinks = defs.get("Planform", {}).get("properties", {}).get("kinks")
    if kinks is not None:
        kinks["description"] = ("a cranked planform's interior span stations [y, leading-edge x, chord] (m), y "
                                "increasing between 0 and the semispan; leading edge and chord are linear between "
                                "stations; omitted or empty: one trapezoid")
    if "structure" in props:
        props["structure"]["description"] = "the parametric structure, or null: a planform-only wing (external modes)"
    if "origin" in props:
        props["origin"]["description"] = "root leading edge in the source model's frame, m"
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["title"] = "romams wing definition"
    schema["description"] = "WingDefinition.to_dict(): SI units (m, kg, Pa), angles in radians"
    return schema
