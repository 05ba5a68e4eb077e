"""Serializer round trip, repositories, units of work and guarded job transitions on a fresh SQLite database."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import numpy as np
import pytest
from sqlalchemy import inspect

from romams import serialize
from romams.persistence import (
    ACTIVE,
    FINAL,
    JobStatus,
    Store,
    content_hash,
    head_revision,
    open_store,
    rom_key,
    schema_revision,
)
from romams.settings import Settings


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


@pytest.fixture(params=["sqlite", pytest.param("postgresql", marks=pytest.mark.services)])
def store(request, tmp_path) -> Store:
    """A fresh store on SQLite, and (services) on an empty PostgreSQL database brought to head."""
    if request.param == "postgresql":
        url = request.getfixturevalue("pg_url")
        return open_store(Settings(data_dir=tmp_path / "data", database_url=url), migrate=True)
    return open_store(Settings(data_dir=tmp_path / "data"))


def test_open_store_creates_sqlite_at_alembic_head(tmp_path):
    store = open_store(Settings(data_dir=tmp_path / "data"))
    assert (tmp_path / "data" / "romams.db").exists()
    assert schema_revision(store.engine) == head_revision()
    names = set(inspect(store.engine).get_table_names())
    assert {"wings", "bases", "roms", "jobs", "evaluations", "modes_uploads", "alembic_version"} <= names
    # opening again is a no-op
    assert schema_revision(open_store(Settings(data_dir=tmp_path / "data")).engine) == head_revision()
    assert store.ping() == "sqlite"


def test_wings_bases_roms_evaluations(store):
    wid = store.wings.ensure(Named("wing-a", 1.0))
    assert store.wings.ensure(Named("wing-a", 2.0)) == wid  # by name
    with pytest.raises(ValueError, match="name"):
        store.wings.create(Named("wing-a", 3.0))
    assert store.wings.find("wing-a")[0] == wid and store.wings.find(wid)[1] == Named("wing-a", 1.0)
    assert store.wings.find("nope") is None and store.wings.find(999) is None
    assert [w["name"] for w in store.wings.all()] == ["wing-a"]

    obj = _outer()
    b1 = store.bases.save(wid, obj, {"samples": 5})
    b2 = store.bases.save(wid, obj, {"samples": 6})
    bid, basis = store.bases.latest(wid)
    assert bid == b2 > b1 and np.array_equal(basis.shapes, obj.shapes)
    assert [b["params"]["samples"] for b in store.bases.of_wing(wid)] == [6, 5]
    assert store.bases.wing_id(b1) == wid and store.bases.wing_id(999) is None
    with pytest.raises(KeyError):
        store.bases.load(999)

    params = {"solver": "uvlm", "na": 8, "nb": 8}
    rom = Inner(np.ones(3), "rom", 0.87)
    rid = store.roms.save(wid, bid, rom, {**params, "mach": 0.87})
    found = store.roms.find(wid, bid, 0.87, {**params, "mach": 0.87})
    assert found is not None and found[0] == rid and np.array_equal(found[1].omega, rom.omega)
    assert store.roms.find(wid, bid, 0.87, {**params, "mach": 0.87, "na": 6}) is None
    assert rom_key(wid, bid, 0.87, params) == rom_key(wid, bid, 0.8700000001, params)
    rid2 = store.roms.save(wid, bid, rom, {**params, "mach": 0.87})  # same identity replaces
    assert [r["id"] for r in store.roms.of_wing(wid)] == [rid2]

    h = content_hash("eval", wid, [1.0, 2.0])
    eid = store.evaluations.save(wid, obj, summary={"mass_kg": 1.25}, request={"design": [1, 2]}, basis_id=bid,
                                 content_hash=h)
    ev = store.evaluations.get(eid, full=True)
    assert ev["summary"] == {"mass_kg": 1.25} and np.array_equal(ev["result"].shapes, obj.shapes)
    assert store.evaluations.find(h)["id"] == eid
    assert [e["id"] for e in store.evaluations.recent(wid)] == [eid]

    mid = store.modes.save(Inner(np.arange(2.0), "m", 1.0), "json", "x.json", summary={"n": 2})
    assert store.modes.load(mid).label == "m"


def test_a_unit_of_work_commits_together_or_not_at_all(store):
    with store.unit_of_work() as uow:
        wid = uow.wings.create(Named("wing-u", 1.0))
        bid = uow.bases.save(wid, _outer(), {"samples": 1})
        assert uow.bases.latest_id(wid) == bid  # visible inside the unit before the commit
        with pytest.raises(ValueError, match="already exists"):  # a refused insert leaves the unit usable
            uow.wings.create(Named("wing-u", 2.0))
        jid = uow.jobs.create("basis", {}, wing_id=wid)
    assert store.bases.latest_id(wid) == bid and store.jobs.status(jid) == JobStatus.QUEUED

    with pytest.raises(RuntimeError, match="boom"), store.unit_of_work() as uow:
        other = uow.wings.create(Named("wing-v", 1.0))
        uow.jobs.create("basis", {}, wing_id=other, job_id="rolled-back")
        raise RuntimeError("boom")
    assert store.wings.find("wing-v") is None and store.jobs.get("rolled-back") is None


def test_job_status_enum_is_the_stored_text():
    assert JobStatus("queued") is JobStatus.QUEUED and JobStatus.FAILED == "failed"
    assert f"{JobStatus.RUNNING}" == "running" and JobStatus.RUNNING.value == "running"
    assert FINAL == {"succeeded", "failed", "cancelled"} and ACTIVE == {"queued", "running"}
    assert JobStatus.CANCELLED.is_final and not JobStatus.QUEUED.is_final


def test_job_transitions_are_guarded(store):
    jid = store.jobs.create("training", {"mach": 0.8}, key="k1")
    assert store.jobs.get(jid)["status"] == "queued" and store.jobs.find_active("k1")["id"] == jid
    assert store.jobs.status(jid) is JobStatus.QUEUED and store.jobs.status("nope") is None
    assert store.jobs.start(jid, max_deliveries=2) == (True, 1)
    assert store.jobs.progress(jid, 0.25, "a quarter")
    assert store.jobs.get(jid)["progress"] == pytest.approx(0.25, abs=1e-12)
    assert store.jobs.start(jid, max_deliveries=2) == (True, 2)  # a redelivery
    ok, n = store.jobs.start(jid, max_deliveries=2)  # third delivery: over the cap -> failed with reason
    assert not ok and n == 3
    job = store.jobs.get(jid)
    assert job["status"] == "failed" and "3 times" in job["error"] and job["finished_at"]
    assert type(job["status"]) is str  # the API and dashboard see the plain text
    assert not store.jobs.finish(jid, JobStatus.SUCCEEDED)  # final states are final
    assert not store.jobs.progress(jid, 0.9)
    assert store.jobs.find_active("k1") is None
    assert [j["id"] for j in store.jobs.recent(status=JobStatus.FAILED)] == [jid]

    parent = store.jobs.create("basis", {}, stage=None)
    child = store.jobs.create("basis-chunk", {}, parent_id=parent)
    assert store.jobs.claim_stage(parent, None, "fanout") and not store.jobs.claim_stage(parent, None, "fanout")
    assert store.jobs.stage(parent) == "fanout" and store.jobs.stage(child) is None
    store.jobs.start(child, 3)
    assert store.jobs.cancel(parent)
    assert store.jobs.get(child)["status"] == "cancelled"
    assert not store.jobs.progress(child, 0.5)  # a worker sees the cancellation at its next progress step
    assert not store.jobs.cancel(parent)
    with pytest.raises(ValueError, match="status"):
        store.jobs.finish(parent, "running")

    art = store.jobs.create("basis-chunk", {})
    store.artifacts.save(art, "snapshots", np.eye(2))
    store.artifacts.save(art, "snapshots", np.eye(3))  # replaces
    assert store.artifacts.load(art, "snapshots").shape == (3, 3)
    with pytest.raises(KeyError):
        store.artifacts.load(art, "other")


def test_a_cancel_racing_the_fan_out_never_leaves_a_child_queued(store):
    """A cancel that arrives while the worker's unit of work creates the chunks waits for it and cancels them; one
    that arrives first leaves nothing to create (the race a fan-out job had with its cancel)."""
    import threading
    import time

    params = [{"index": i} for i in range(3)]
    parent = store.jobs.create("basis", {})
    assert store.jobs.start(parent, max_deliveries=3) == (True, 1)
    outcome: list[bool] = []
    with store.unit_of_work() as uow:
        kids = uow.jobs.fan_out(parent, "basis-chunk", params, wing_id=None)
        assert kids is not None and [k["params"]["index"] for k in kids] == [0, 1, 2]
        canceller = threading.Thread(target=lambda: outcome.append(store.jobs.cancel(parent)))
        canceller.start()
        time.sleep(0.3)
        assert canceller.is_alive()  # the parent's row is held until the chunks are committed
    canceller.join(30)
    assert outcome == [True]
    assert {k["status"] for k in store.jobs.children(parent)} == {"cancelled"}
    with store.unit_of_work() as uow:  # a re-delivery of the cancelled parent creates nothing
        assert uow.jobs.fan_out(parent, "basis-chunk", params) is None

    late = store.jobs.create("basis", {})
    assert store.jobs.start(late, max_deliveries=3) == (True, 1)
    assert store.jobs.cancel(late)
    with store.unit_of_work() as uow:
        assert uow.jobs.fan_out(late, "basis-chunk", params) is None
    assert store.jobs.children(late) == []

    again = store.jobs.create("basis", {})
    store.jobs.start(again, max_deliveries=3)
    with store.unit_of_work() as uow:
        first = [k["id"] for k in uow.jobs.fan_out(again, "basis-chunk", params) or []]
    with store.unit_of_work() as uow:  # a re-delivered running parent finds its first chunks
        assert [k["id"] for k in uow.jobs.fan_out(again, "basis-chunk", params) or []] == first and len(first) == 3


def test_worker_lru_cache_is_bounded():
    from worker.cache import LruCache

    c = LruCache(2)
    loads = []
    for key in ["a", "b", "a", "c", "b", "a"]:
        c.get_or_load(key, lambda k=key: loads.append(k) or k.upper())
    # a, b loaded; a hit; c evicts b; b reloaded evicts a; a reloaded
    assert loads == ["a", "b", "c", "b", "a"] and len(c) == 2 and c.hits == 1 and c.misses == 5


def test_rows_written_before_the_flutter_package_split_still_load():
    """A FlutterResult stored under its old class path ('romams_core.flutter:FlutterResult', before the module
    became a package, without the fields added since) loads as today's class with their defaults."""
    import json

    from romams import serialize
    from romams_core.flutter import FlutterResult

    r = FlutterResult(**{**serialize_fields_of_old_row(), "v": np.linspace(1.0, 2.0, 3)})
    meta, blob = serialize.dumps(r)
    text = json.dumps(meta).replace("romams_core.flutter.result:FlutterResult", "romams_core.flutter:FlutterResult")
    old = json.loads(text)
    assert old["tree"]["__dataclass__"] == "romams_core.flutter:FlutterResult"
    for key in ("v_eas_m_s", "altitude_ref_m", "v_eas", "lag_root_flagged"):
        old["tree"]["fields"].pop(key)
    back = serialize.loads(old, blob)
    assert type(back) is FlutterResult and back.q_flutter_pa == 1234.5
    assert back.v_eas_m_s is None and back.altitude_ref_m is None and back.v_eas.size == 0
    np.testing.assert_array_equal(back.v, r.v)


def serialize_fields_of_old_row() -> dict:
    """Scalar fields a FlutterResult row of the first release carried."""
    return dict(mach=0.87, sweep="constant-speed", coupling="tustin", flutter_found=True, v_flutter_m_s=200.0,
                omega_flutter_rad_s=500.0, q_flutter_pa=1234.5, rho_flutter=0.3, altitude_m=None, k_flutter=0.4,
                v_true_m_s=260.0, flutter_mode=2, sdoff=False, energy_share=0.6, frequency_separation=0.1,
                single_mode_unstable=False, message="m", rho_ref=0.41, a_ref=299.5, c_ref=0.37, dt_star=0.1)


def test_worker_result_cache_is_bounded_by_entries_and_json_bytes():
    from worker.cache import ResultCache

    summary = {"mass_kg": 1.25, "results": [{"mach": 0.87, "v_flutter_m_s": 250.5, "sdoff": False}], "note": "x"}
    size = len(json.dumps(summary, separators=(",", ":")))
    c = ResultCache(maxsize=100, maxbytes=3 * size)
    for k in range(5):
        c.put(k, {**summary, "note": str(k)})
    assert len(c) == 3 and c.bytes == 3 * size  # the oldest two evicted by bytes, not by count
    assert c.get(0) is None and c.get(4) == {**summary, "note": "4"}
    hit = c.get(3)
    hit["mass_kg"] = 0.0  # a hit is a copy: the cached summary does not change
    assert c.get(3)["mass_kg"] == 1.25
    c = ResultCache(maxsize=2, maxbytes=10**6)
    for k in range(3):
        c.put(k, summary)
    assert len(c) == 2 and c.get(0) is None and c.bytes == 2 * size
