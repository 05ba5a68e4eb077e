"""Schemathesis over the whole OpenAPI surface (ASGI transport, bounded examples): every response the API sends is
documented, with its status code, content type, headers and schema, and no input gives a 5xx.

The app runs on a temporary SQLite store with the embedded Celery app (no worker: a synchronous evaluation answers
202 after ``sync_timeout_s``). The store holds real rows for the id paths to hit: a wing, a basis, a DLM ROM, a
stored evaluation and the jobs that made them. Generated cases (positive and negative) carry a valid API key; a
second pass sends none (401) or a made-up one (403) to every route but the health check; a third runs
schemathesis' own engine (examples, coverage and stateful phases).
"""

from __future__ import annotations

import contextlib
import os
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import schemathesis
from fast_settings import RFA_FAST
from fastapi.testclient import TestClient
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st
from hypothesis.errors import Unsatisfiable
from schemathesis.checks import not_a_server_error
from schemathesis.generation import GenerationMode
from schemathesis.specs.openapi.checks import (
    content_type_conformance,
    negative_data_rejection,
    response_headers_conformance,
    response_schema_conformance,
    status_code_conformance,
)

from api.app import create_app
from romams.settings import Settings

KEY = "schemathesis-key"
CHECKS = [not_a_server_error, status_code_conformance, content_type_conformance, response_headers_conformance,
          response_schema_conformance, negative_data_rejection]
#: generated cases per operation and mode (CI budget; ROMAMS_FUZZ_EXAMPLES raises it for a deeper local run)
EXAMPLES = int(os.environ.get("ROMAMS_FUZZ_EXAMPLES", "20"))


def _seed(app, client: TestClient) -> dict[str, int]:
    """Real rows: a wing, its active basis (random 2-shape basis), a DLM ROM trained in this process, and a stored
    evaluation of the baseline; returns their ids."""
    import worker.context
    import worker.evaluation
    import worker.tasks
    from romams_core.basis import build_basis
    from romams_core.mesh import standard_mesh
    from romams_core.wing import template
    from worker.cache import LruCache

    store = app.state.service.store
    auth = {"Authorization": f"Bearer {KEY}"}
    wid = client.post("/api/v1/wings", json={"template": "cropped-delta"}, headers=auth).json()["id"]
    n = standard_mesh(template("cropped-delta").planform).n_nodes
    snaps = np.linalg.qr(np.random.default_rng(0).standard_normal((n, 2)))[0]
    bid = store.bases.save(wid, build_basis(snaps, n_modes=2), {"samples": 2, "modes": 2})
    store.wings.set_active_basis(wid, bid)
    with pytest.MonkeyPatch.context() as mp:  # the worker's code on this store, with caches of its own
        mp.setattr(worker.context, "_STORE", [store])
        cache = LruCache(8)
        mp.setattr(worker.context, "OBJECTS", cache)
        mp.setattr(worker.evaluation, "OBJECTS", cache)
        job = client.post(f"/api/v1/wings/{wid}/roms", json={"mach": 0.5, "options": RFA_FAST}, headers=auth).json()
        worker.tasks.training_job(job["job_id"])
        rom_id = store.jobs.get(job["job_id"])["result"]["rom_id"]
        summary, result = worker.evaluation.evaluate(wid, bid, [[0.5, rom_id]], None)
    eid = store.evaluations.save(wid, result, summary=summary, request={}, basis_id=bid, method="rom-ams")
    return {"wing": wid, "basis": bid, "rom": rom_id, "evaluation": eid}


@contextlib.contextmanager
def seeded(data: Path) -> Iterator[tuple[Any, TestClient, dict[str, object]]]:
    """(app, client, real path parameters) on a fresh store under ``data`` with real rows behind the ids (also used
    by benchmarks.reliability)."""
    app = create_app(Settings(data_dir=data, api_keys=[KEY], sync_timeout_s=0.05, max_samples=50), sweeper=False)
    with TestClient(app) as client:
        ids = _seed(app, client)
        job = client.get("/api/v1/jobs", headers={"Authorization": f"Bearer {KEY}"}).json()[0]["id"]
        real = {"wing": str(ids["wing"]), "basis_id": ids["basis"], "rom_id": ids["rom"],
                "evaluation_id": ids["evaluation"], "job_id": job}
        yield app, client, real


@pytest.fixture(scope="module")
def api(tmp_path_factory):
    """(schema bound to the app, real path parameters, app) on a seeded store."""
    with seeded(tmp_path_factory.mktemp("schemathesis")) as (app, _, real):
        yield schemathesis.openapi.from_asgi("/openapi.json", app), real, app


def _cases(operation, mode: GenerationMode, real: dict[str, object]) -> st.SearchStrategy:
    """Generated cases of one operation; half of them on the ids of real rows."""
    names = {p for p in real if "{" + p + "}" in operation.path}
    generated = operation.as_strategy(generation_mode=mode)
    if not names:
        return generated
    return st.one_of(generated, operation.as_strategy(generation_mode=mode,
                                                      path_parameters={k: real[k] for k in names}))


def _first_failure(exc: BaseException) -> str:
    """The first line of each failure in a schemathesis failure group (or of an exception)."""
    inner = exc.exceptions if isinstance(exc, BaseExceptionGroup) else [exc]
    return "; ".join(f"{type(e).__name__}: {str(e).strip().splitlines()[0] if str(e).strip() else ''}"
                     for e in inner)


def _failures(operation, strategy: st.SearchStrategy, headers: dict[str, str], examples: int,
              seen: Counter) -> list[str]:
    """Failures of the checks over ``examples`` generated cases of one operation (empty: none); ``seen`` counts
    the (status, content type) pairs of the responses."""
    found: list[str] = []

    @given(case=strategy)
    @settings(max_examples=examples, deadline=None, database=None, phases=[Phase.explicit, Phase.generate],
              suppress_health_check=list(HealthCheck))
    def run(case) -> None:
        try:
            response = case.call(headers={} if _negates_the_key(case) else headers)
            seen[(response.status_code, _content_type(response))] += 1
            case.validate_response(response, checks=CHECKS)
        except (Exception, BaseExceptionGroup) as exc:  # noqa: BLE001 - failed checks, or a request not made
            found.append(f"{operation.label}: {_first_failure(exc)}\n    {case.as_curl_command()}")
    try:
        run()
    except Unsatisfiable:  # negative mode on an operation without input: nothing to negate
        pass
    return found


def fuzz(schema, real: dict[str, object], mode: GenerationMode, examples: int, seen: Counter) -> list[str]:
    """Failures of the checks over ``examples`` generated cases (with our key) of every operation; ``seen`` counts
    the (status, content type) pairs of the responses."""
    failures: list[str] = []
    for result in schema.get_all_operations():
        op = result.ok()
        failures += _failures(op, _cases(op, mode, real), {"Authorization": f"Bearer {KEY}"}, examples, seen)
    return failures


def _negates_the_key(case) -> bool:
    """True when a negative case's mutation is a missing or wrong ``Authorization`` header (the Bearer scheme
    makes it a required header): then our key must not replace it, and the answer is a 401/403."""
    data = getattr(getattr(case.meta, "phase", None), "data", None)
    return any(getattr(m, "parameter", None) == "Authorization" for m in getattr(data, "mutations", None) or ())


def _content_type(response) -> str:
    """Media type of a response (without parameters)."""
    value = response.headers.get("content-type") or ""
    return (value[0] if isinstance(value, list) else value).split(";")[0]


@pytest.mark.parametrize("mode", [GenerationMode.POSITIVE, GenerationMode.NEGATIVE])
def test_every_response_is_documented_and_no_input_gives_a_5xx(api, mode):
    schema, real, _ = api
    seen: Counter = Counter()
    failures = fuzz(schema, real, mode, EXAMPLES, seen)
    assert not failures, f"{len(failures)} failures:\n" + "\n".join(sorted(set(failures))[:60])
    statuses = {status for status, _ in seen}
    assert not any(s >= 500 for s in statuses), seen
    assert {404, 422} <= statuses, seen  # real rows and made-up ids, valid and invalid input
    if mode == GenerationMode.POSITIVE:
        assert {200, 202} <= statuses and seen[(200, "image/png")] + seen[(200, "image/svg+xml")] > 0, seen


def test_without_a_valid_key_every_route_but_health_answers_a_documented_401_or_403(api):
    """No key of ours: schemathesis sends none (401) or makes one up from the Bearer security scheme (403), on the
    mutating routes and (keys configured: reads need a read key) on the reads."""
    schema, real, _ = api
    failures: list[str] = []
    seen: Counter = Counter()
    for result in schema.get_all_operations():
        op = result.ok()
        if op.path != "/api/v1/health":
            failures += _failures(op, _cases(op, GenerationMode.POSITIVE, real), {}, 4, seen)
    assert not failures, f"{len(failures)} failures:\n" + "\n".join(sorted(set(failures))[:60])
    assert 401 in {status for status, _ in seen} and {status for status, _ in seen} <= {401, 403}, seen


#: schemathesis' own runner: its explicit examples, its coverage phase (boundary values, each parameter missing,
#: wrong types, unsupported methods) and its stateful phase (responses' ids fed into later requests), with every
#: check it has except positive_data_acceptance: this API validates what a schema cannot say (a design's variable
#: names and bounds belong to the wing, an upload's content must be modes, at most one of design/modes/modes_id)
ENGINE_CONFIG = {
    "headers": {"Authorization": f"Bearer {KEY}"},
    "checks": {"positive_data_acceptance": {"enabled": False}},
    "phases": {"examples": {"enabled": True}, "coverage": {"enabled": True}, "fuzzing": {"enabled": False},
               "stateful": {"enabled": True}},
    "generation": {"max-examples": 10},
}


def test_coverage_and_stateful_phases_find_nothing(api):
    from schemathesis.config import SchemathesisConfig
    from schemathesis.engine import events, from_schema

    _, _, app = api
    schema = schemathesis.openapi.from_asgi("/openapi.json", app, config=SchemathesisConfig.from_dict(ENGINE_CONFIG))
    failures, errors, statuses = [], [], Counter()
    for event in from_schema(schema).execute():
        if isinstance(event, events.ScenarioFinished):
            statuses.update(i.response.status_code for i in event.recorder.interactions.values() if i.response)
            failures += [f"{event.label}: {c.name}: {c.failure_info.failure.title}"
                         for checks in event.recorder.checks.values() for c in checks if c.failure_info]
        elif isinstance(event, events.NonFatalError | events.FatalError):
            errors.append(str(getattr(event, "info", event))[:500])
    assert not errors, errors[:10]
    assert not failures, sorted(set(failures))
    assert sum(statuses.values()) > 300 and {200, 404, 405, 422} <= set(statuses), statuses
    assert not any(s >= 500 for s in statuses), statuses
