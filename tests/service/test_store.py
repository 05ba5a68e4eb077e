"""Serializer round trip, store repositories and guarded job transitions on a fresh SQLite database."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pytest
from sqlalchemy import inspect

from romams import serialize
from romams.settings import Settings
from romams.store import Store, content_hash, head_revision, open_store, rom_key, schema_revision


@serialize.register
@dataclass(frozen=True)
class Inner:
    omega: np.ndarray
    label: str
    scale: float


@serialize.register
@dataclass
class Outer:
    shapes: np.ndarray
    inner: Inner
    per_mach: list[Inner]
    info: dict
    pair: tuple
    n: int
    z: complex
    bad: float
    cached: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        self.cached = self.shapes.sum(axis=0)


@serialize.register
@dataclass(frozen=True)
class Named:
    name: str
    value: float

    def to_dict(self) -> dict:
        return {"name": self.name, "value": self.value, "tag": "named"}

    @classmethod
    def from_dict(cls, d: dict) -> Named:
        assert d["tag"] == "named"
        return cls(d["name"], d["value"])


def _outer() -> Outer:
    rng = np.random.default_rng(1)
    return Outer(
        shapes=rng.standard_normal((187, 4)),
        inner=Inner(np.array([1.0, 2.5]), "a", 3.0),
        per_mach=[Inner(np.arange(3.0) * m, f"M{m}", m) for m in (0.79, 0.87)],
        info={"ints": np.arange(5, dtype=np.int32), "nested": {"x": [1, 2, {"y": np.eye(2)}]}},
        pair=(1, "two", np.float64(3.5)),
        n=7,
        z=complex(1.0, -2.0),
        bad=math.nan,
    )


def test_serializer_round_trip_preserves_arrays_and_structure():
    obj = _outer()
    meta, blob = serialize.dumps(obj)
    back = serialize.loads(meta, blob)
    assert isinstance(back, Outer) and isinstance(back.inner, Inner)
    np.testing.assert_array_equal(back.shapes, obj.shapes)
    assert back.shapes.dtype == np.float64
    np.testing.assert_array_equal(back.cached, obj.cached)  # init=False field restored
    assert [p.label for p in back.per_mach] == ["M0.79", "M0.87"]
    np.testing.assert_allclose(back.per_mach[1].omega, [0.0, 0.87, 1.74], rtol=0, atol=1e-15)
    assert back.info["ints"].dtype == np.int32 and back.info["nested"]["x"][2]["y"].shape == (2, 2)
    assert back.pair == (1, "two", 3.5) and back.n == 7 and back.z == complex(1, -2)
    assert math.isnan(back.bad)
    # the JSON meta records every array's shape and dtype, and contains no NaN literal
    arrays = [v for v in _walk(meta) if isinstance(v, dict) and "__ndarray__" in v]
    assert {tuple(a["shape"]) for a in arrays} >= {(187, 4), (2,), (5,)}


def _walk(x):
    yield x
    if isinstance(x, dict):
        for v in x.values():
            yield from _walk(v)
    elif isinstance(x, list):
        for v in x:
            yield from _walk(v)


def test_serializer_uses_to_dict_and_refuses_pickles():
    meta, blob = serialize.dumps({"w": Named("cd", 1.5)})
    assert serialize.loads(meta, blob)["w"] == Named("cd", 1.5)
    with pytest.raises(ValueError, match="object arrays"):
        serialize.dumps(np.array([object()], dtype=object))
    with pytest.raises(ValueError, match="not allowed"):
        serialize.loads({"format": 1, "tree": {"__dataclass__": "os:PathLike", "fields": {}}}, blob)


def test_to_jsonable_maps_nonfinite_to_none():
    assert serialize.to_jsonable({"a": np.array([1.0, np.inf]), "b": np.float32(2.0)}) == {"a": [1.0, None], "b": 2.0}


@pytest.fixture()
def store(tmp_path) -> Store:
    return open_store(Settings(data_dir=tmp_path / "data"))


def test_open_store_creates_sqlite_at_alembic_head(tmp_path, store):
    assert (tmp_path / "data" / "romams.db").exists()
    assert schema_revision(store.engine) == head_revision()
    names = set(inspect(store.engine).get_table_names())
    assert {"wings", "bases", "roms", "jobs", "evaluations", "modes_uploads", "alembic_version"} <= names
    # opening again is a no-op
    assert schema_revision(open_store(Settings(data_dir=tmp_path / "data")).engine) == head_revision()


def test_wings_bases_roms_evaluations(store):
    wid = store.ensure_wing(Named("wing-a", 1.0))
    assert store.ensure_wing(Named("wing-a", 2.0)) == wid  # by name
    with pytest.raises(ValueError, match="name"):
        store.create_wing(Named("wing-a", 3.0))
    assert store.find_wing("wing-a")[0] == wid and store.find_wing(wid)[1] == Named("wing-a", 1.0)
    assert store.find_wing("nope") is None and store.find_wing(999) is None
    assert [w["name"] for w in store.list_wings()] == ["wing-a"]

    obj = _outer()
    b1 = store.save_basis(wid, obj, {"samples": 5})
    b2 = store.save_basis(wid, obj, {"samples": 6})
    bid, basis = store.latest_basis(wid)
    assert bid == b2 > b1 and np.array_equal(basis.shapes, obj.shapes)
    assert [b["params"]["samples"] for b in store.list_bases(wid)] == [6, 5]

    params = {"solver": "uvlm", "na": 8, "nb": 8}
    rom = Inner(np.ones(3), "rom", 0.87)
    rid = store.save_rom(wid, bid, rom, {**params, "mach": 0.87})
    found = store.find_rom(wid, bid, 0.87, {**params, "mach": 0.87})
    assert found is not None and found[0] == rid and np.array_equal(found[1].omega, rom.omega)
    assert store.find_rom(wid, bid, 0.87, {**params, "mach": 0.87, "na": 6}) is None
    assert rom_key(wid, bid, 0.87, params) == rom_key(wid, bid, 0.8700000001, params)
    rid2 = store.save_rom(wid, bid, rom, {**params, "mach": 0.87})  # same identity replaces
    assert [r["id"] for r in store.list_roms(wid)] == [rid2]

    h = content_hash("eval", wid, [1.0, 2.0])
    eid = store.save_evaluation(wid, obj, summary={"mass_kg": 1.25}, request={"design": [1, 2]}, basis_id=bid,
                                content_hash=h)
    ev = store.get_evaluation(eid, full=True)
    assert ev["summary"] == {"mass_kg": 1.25} and np.array_equal(ev["result"].shapes, obj.shapes)
    assert store.find_evaluation(h)["id"] == eid
    assert [e["id"] for e in store.list_evaluations(wid)] == [eid]


def test_job_transitions_are_guarded(store):
    jid = store.create_job("training", {"mach": 0.8}, key="k1")
    assert store.get_job(jid)["status"] == "queued" and store.find_active_job("k1")["id"] == jid
    assert store.start_job(jid, max_deliveries=2) == (True, 1)
    assert store.set_progress(jid, 0.25, "a quarter")
    assert store.get_job(jid)["progress"] == pytest.approx(0.25, abs=1e-12)
    assert store.start_job(jid, max_deliveries=2) == (True, 2)  # a redelivery
    ok, n = store.start_job(jid, max_deliveries=2)  # third delivery: over the cap -> failed with reason
    assert not ok and n == 3
    job = store.get_job(jid)
    assert job["status"] == "failed" and "3 times" in job["error"] and job["finished_at"]
    assert not store.finish_job(jid, "succeeded")  # final states are final
    assert not store.set_progress(jid, 0.9)
    assert store.find_active_job("k1") is None

    parent = store.create_job("basis", {})
    child = store.create_job("basis-chunk", {}, parent_id=parent)
    store.start_job(child, 3)
    assert store.cancel_job(parent)
    assert store.get_job(child)["status"] == "cancelled"
    assert not store.set_progress(child, 0.5)  # a worker sees the cancellation at its next progress step
    assert not store.cancel_job(parent)
    with pytest.raises(ValueError, match="status"):
        store.finish_job(parent, "running")


def test_worker_lru_cache_is_bounded():
    from worker.cache import LruCache

    c = LruCache(2)
    loads = []
    for key in ["a", "b", "a", "c", "b", "a"]:
        c.get_or_load(key, lambda k=key: loads.append(k) or k.upper())
    # a, b loaded; a hit; c evicts b; b reloaded evicts a; a reloaded
    assert loads == ["a", "b", "c", "b", "a"] and len(c) == 2 and c.hits == 1 and c.misses == 5
