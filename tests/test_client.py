"""RomamsClient and FlutterProblem against a live embedded service (``romams serve`` subprocess).

The service runs with an API key, a small synchronous-batch limit (so the 202-job path of batches is
exercised) and a cropped-delta wing with a small basis and ROMs at two Mach numbers.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys

import numpy as np
import pytest
from fast_settings import DLM_FAST
from live_service import ROOT, LiveService

from client import FlutterProblem, JobError, RomamsClient, RomamsError

KEY = "test-key-123"
MACHS = (0.87, 0.95)
PAPER_OPTIMUM = [0.1535, 0.6135, 0.8247, 0.0203, 1.966, 0.8787, 0.5972]
CI = os.environ.get("CI", "").lower() == "true"


@pytest.fixture(scope="module")
def service(tmp_path_factory):
    with LiveService(tmp_path_factory.mktemp("romams-client"), api_keys=KEY, batch_sync_max=4, batch_chunk=2) as s:
        yield s


@pytest.fixture(scope="module")
def client(service):
    with RomamsClient(service.url, api_key=KEY, timeout=60, retries=2, backoff=0.2) as c:
        yield c


@pytest.fixture(scope="module")
def wing(client):
    """Id of a cropped-delta wing with a basis (10 samples) and ROMs at MACHS."""
    wid = client.ensure_wing("cd-client", "cropped-delta")
    job = client.wait_job(client.start_basis(wid, samples=10, modes=4, seed=3), timeout_s=300, progress=False)
    assert job["result"]["n_basis"] >= 1
    client.train(wid, list(MACHS), options={"reduce_order": "auto", **DLM_FAST}, timeout_s=600, progress=False)
    return wid


def test_client_imports_only_httpx_tqdm_numpy() -> None:
    code = ("import sys, client, client.http, client.problem, client.errors, client.openmdao\n"
            "bad = sorted({m.split('.')[0] for m in sys.modules} & {'romams_core', 'romams', 'api', 'worker', "
            "'scipy', 'sqlalchemy', 'fastapi', 'celery', 'matplotlib', 'openmdao', 'pydantic'})\n"
            "print(','.join(bad))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == ""


def test_health_and_api_key(service, client) -> None:
    assert client.health()["status"] == "ok"
    with RomamsClient(service.url, retries=0) as anonymous:
        assert anonymous.health()["status"] == "ok"  # the health check is open
        with pytest.raises(RomamsError) as ei:
            anonymous.list_wings()  # with keys configured, reading needs a (read) key too
        assert (ei.value.status, ei.value.field) == (401, "authorization")
        with pytest.raises(RomamsError) as ei:
            anonymous.create_wing("cropped-delta", "no-key")
        assert (ei.value.status, ei.value.field) == (401, "authorization")
    with RomamsClient(service.url, api_key="wrong", retries=0) as wrong:
        with pytest.raises(RomamsError) as ei:
            wrong.create_wing("cropped-delta", "bad-key")
        assert (ei.value.status, ei.value.field) == (403, "authorization")


def test_problem_details_carry_status_and_field(client, wing) -> None:
    cases = [
        (lambda: client.create_wing("no-such-template", "x"), 422, "template"),
        (lambda: client.get_wing("no-such-wing"), 404, "wing"),
        (lambda: client.evaluate(wing, [0.9, 0.5, 0.7, 0.05, 1.0, 1.0, 0.8]), 422, "design.x1"),
        (lambda: client.evaluate(wing, {"x1": 0.3}), 422, "design"),
        (lambda: client.evaluate_batch(wing, [PAPER_OPTIMUM, PAPER_OPTIMUM[:6]]), 422, "designs[1]"),
        (lambda: client.evaluate(wing, None, machs=[0.5]), 422, "machs[0]"),
        (lambda: client.start_training(wing, 1.2), 422, "mach"),
        (lambda: client.start_basis(wing, samples=1), 422, "samples"),
        (lambda: client.get_job("no-such-job"), 404, "job_id"),
    ]
    for call, status, field in cases:
        with pytest.raises(RomamsError) as ei:
            call()
        err = ei.value
        assert err.status == status, err
        assert err.field is not None and err.field.split(".")[0] == field.split(".")[0], err
        if "." in field or "[" in field:
            assert err.field == field, err
        assert err.detail and err.body["status"] == status


def test_ensure_wing_is_idempotent(client) -> None:
    a = client.ensure_wing("cd-ensure", "cropped-delta")
    assert client.ensure_wing("cd-ensure", "cropped-delta") == a
    info = client.get_wing("cd-ensure")
    assert info["id"] == a and [v["name"] for v in info["design_variables"]] == [f"x{i}" for i in range(1, 8)]


def test_training_is_listed_and_resubmission_returns_existing(client, wing) -> None:
    roms = client.list_roms(wing)
    assert sorted(round(r["mach"], 6) for r in roms) == list(MACHS)
    items = client.start_training(wing, list(MACHS), options={"reduce_order": "auto", **DLM_FAST})
    assert all(i["existing"] and i["rom_id"] is not None for i in items)
    assert sorted(client.get_wing(wing)["trained_machs"]) == list(MACHS)


def test_failed_job_raises_job_error(client, wing) -> None:
    items = client.start_training(wing, 0.8, solver="uvlm", options={"nrmse_tol": 1e-12})
    with pytest.raises(JobError) as ei:
        client.wait_job(items[0]["job_id"], timeout_s=300, progress=False)
    assert ei.value.job["status"] == "failed"
    assert "NRMSE" in ei.value.detail


def test_evaluate_baseline_vg_and_plots(client, wing) -> None:
    out = client.evaluate(wing, None)
    assert out["mass_kg"] == pytest.approx(0.24, rel=0.02)  # calibrated bare plate (paper: 0.24 kg)
    f = out["frequencies_hz"]
    assert f[:3] == pytest.approx([26.7, 88.2, 131.8], rel=0.03)  # measured (Schairer & Hand)
    assert len(out["mac"]) == 4 and min(out["mac"]) > 0.9
    assert [r["mach"] for r in out["results"]] == list(MACHS)
    for r in out["results"]:
        assert {"mach", "v_flutter_m_s", "omega_flutter_rad_s", "q_flutter_pa", "sdoff", "flutter_mode",
                "safe_altitude_m"} <= set(r)
    vg = client.vg_data(out["evaluation_id"])
    assert [m["mach"] for m in vg["machs"]] == list(MACHS)
    first = vg["machs"][0]
    assert len(first["v_m_s"]) == len(first["g"]) >= 10
    png = client.plot(out["evaluation_id"], "png")
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 5000
    svg = client.plot(out["evaluation_id"], "svg", kind="envelope")
    assert b"<svg" in svg[:2000]
    on_q = client.plot(out["evaluation_id"], "svg", axis="q", mach=MACHS[-1])  # another axis, another Mach
    assert b"<svg" in on_q[:2000] and on_q != client.plot(out["evaluation_id"], "svg")
    with pytest.raises(ValueError, match="axis"):
        client.plot(out["evaluation_id"], "png", axis="mach")


def test_gaf_table_from_an_own_code_through_the_client(client, wing) -> None:
    """basis_shapes() -> a doublet lattice of our own (the DLM on one box per panel, standing in for a user's code)
    -> import_gaf() -> flutter with solver external:<label>: close to the service's dlm ROM of the same lattice
    (that one is balanced-reduced, reduce_order="auto": about 1 % apart)."""
    import io

    from romams_core.aero.dlm import DlmSolver
    from romams_core.mesh import standard_mesh
    from romams_core.training_rfa import DEFAULT_K_VALUES
    from romams_core.wing import template

    bid = client.get_wing(wing)["active_basis_id"]
    arrays = client.basis_shapes(bid)
    mesh = standard_mesh(template("cropped-delta").planform)
    np.testing.assert_allclose(arrays["x"], mesh.x)
    k = np.asarray(DEFAULT_K_VALUES)
    gaf = DlmSolver(refine=1).gaf(mesh, arrays["shapes"], 0.95, k)
    buf = io.BytesIO()
    np.savez(buf, k=k, gaf_real=gaf.real, gaf_imag=gaf.imag, mach=0.95)
    rom = client.import_gaf(wing, buf.getvalue(), "own-dlm")
    assert rom["solver"] == "external:own-dlm" and rom["mach"] == 0.95 and rom["basis_id"] == bid
    own = client.evaluate(wing, None, machs=[0.95], solver="external:own-dlm", store=False)["results"][0]
    ref = client.evaluate(wing, None, machs=[0.95], solver="dlm", store=False)["results"][0]
    assert own["solver"] == "external:own-dlm" and own["flutter_mode"] == ref["flutter_mode"]
    assert own["q_flutter_pa"] == pytest.approx(ref["q_flutter_pa"], rel=0.03)
    with pytest.raises(RomamsError) as e:
        client.import_gaf(wing, b"junk", "bad")
    assert e.value.status == 422 and e.value.field == "file"


def _same_result(a: dict, b: dict) -> None:
    """Two result dicts of one design agree (the evaluation is deterministic)."""
    assert a["mass_kg"] == pytest.approx(b["mass_kg"], rel=1e-12)
    assert a["mac"] == pytest.approx(b["mac"], rel=1e-9)
    for ra, rb in zip(a["results"], b["results"], strict=True):
        for key in ("v_flutter_m_s", "omega_flutter_rad_s", "safe_altitude_m"):
            if ra[key] is None:
                assert rb[key] is None
            else:
                assert ra[key] == pytest.approx(rb[key], rel=1e-8), key
        assert ra["sdoff"] == rb["sdoff"]


def test_batch_sync_and_job_paths_agree_with_single_evaluations(client, wing) -> None:
    rng = np.random.default_rng(7)
    info = client.get_wing(wing)
    lo = np.array([v["lower"] for v in info["design_variables"]])
    hi = np.array([v["upper"] for v in info["design_variables"]])
    designs = lo + rng.random((6, lo.size)) * (hi - lo)
    small = client.evaluate_batch(wing, designs[:3])  # <= batch_sync_max: answered synchronously
    large = client.evaluate_batch(wing, designs)  # > batch_sync_max: 202 + job, waited for by the client
    assert len(small) == 3 and len(large) == 6
    for a, b in zip(small, large[:3], strict=True):
        _same_result(a, b)
    single = client.evaluate(wing, designs[4], store=False)
    _same_result(single, large[4])
    split = client.evaluate_batch(wing, designs, max_per_request=4)  # two requests, order kept
    for a, b in zip(split, large, strict=True):
        _same_result(a, b)
    by_name = client.evaluate(wing, dict(zip([f"x{i}" for i in range(1, 8)], designs[4], strict=True)), store=False)
    _same_result(by_name, large[4])


def test_flutter_problem_is_one_batch_per_call_with_paper_penalty(client, wing) -> None:
    mu = 5.0
    prob = FlutterProblem(client, wing, mu=mu)
    assert prob.names == [f"x{i}" for i in range(1, 8)] and list(prob.machs) == list(MACHS)
    rng = np.random.default_rng(11)
    x = prob.denormalize(rng.random((4, prob.dim)))
    sent = client.requests_sent
    obj = prob(x)
    assert client.requests_sent - sent == 1 and prob.n_calls == 1 and prob.n_evaluations == 4
    assert obj.shape == (4,)
    raw = client.evaluate_batch(wing, x)
    for i, r in enumerate(raw):
        env_ok = bool(r["envelope_ok"]) or min(r["envelope_margin_m"]) >= -0.01  # 1 cm tolerance
        feasible = env_ok and not r["sdoff"] and min(r["mac"]) >= 0.98
        assert obj[i] == pytest.approx(r["mass_kg"] + mu * (not feasible), rel=1e-12)
    graded_problem = FlutterProblem(client, wing, mu=mu, penalty="graded")
    graded = graded_problem.evaluate(x)
    excess_km = np.array([sum(max(0.0, -m) for m in r["envelope_margin_m"]) / 1e3 for r in raw])
    expected = [r["mass_kg"] + (0.0 if f else mu * (1.0 + e * (not ok) + max(0.0, 0.98 - min(r["mac"])) / 0.02
                                                   + sum(p["sdoff"] for p in r["results"])))
                for r, f, e, ok in zip(raw, graded.feasible, excess_km, graded.envelope_ok, strict=True)]
    assert graded.objective == pytest.approx(expected, rel=1e-12)
    # the service's run applies the same graded penalty to what it stores (its dashboard's objective)
    stored = {tuple(r["x"]): r["objective"] for r in client.run_evaluations(graded_problem.run_id)["evaluations"]}
    assert client.get_run(graded_problem.run_id)["settings"]["penalty"] == "graded"
    assert [stored[tuple(float(v) for v in xi)] for xi in x] == pytest.approx(graded.objective, rel=1e-9)
    cons = prob.constraints(x)  # same population: no new request
    assert prob.n_calls == 1
    assert cons["envelope_margin_m"].shape == (4, 2) and cons["feasible"].dtype == bool
    assert cons["min_mac"] == pytest.approx([min(r["mac"]) for r in raw], rel=1e-12)
    one = prob(x[0])
    assert isinstance(one, float) and one == pytest.approx(obj[0], rel=1e-12)
    assert prob.for_scipy(x.T) == pytest.approx(obj, rel=1e-12)  # scipy's vectorized layout [d, S]
    with pytest.raises(ValueError, match="x: expected"):
        prob(np.ones((3, 5)))


def test_openmdao_component(client, wing) -> None:
    try:
        import openmdao.api as om
    except ImportError:
        if CI:
            raise
        pytest.skip("openmdao is not installed")
    from client.openmdao import FlutterComponent

    prob = FlutterProblem(client, wing, mu=5.0)
    model = om.Problem()
    model.model.add_subsystem("flutter", FlutterComponent(problem=prob), promotes=["*"])
    model.setup()
    model.set_val("x", np.array(PAPER_OPTIMUM))
    model.run_model()
    ev = prob.evaluate(np.array(PAPER_OPTIMUM))
    assert model.get_val("mass")[0] == pytest.approx(ev.mass_kg[0], rel=1e-12)
    assert model.get_val("objective")[0] == pytest.approx(ev.objective[0], rel=1e-12)
    assert model.get_val("envelope_margin").shape == (2,)
    assert model.get_val("feasible")[0] == float(ev.feasible[0])
    assert math.isfinite(model.get_val("min_mac")[0])


def test_train_returns_one_rom_per_mach(client, wing) -> None:
    rows = client.train(wing, list(MACHS), options={"reduce_order": "auto", **DLM_FAST}, timeout_s=60, progress=False)
    assert sorted(float(r["mach"]) for r in rows) == list(MACHS)  # the ROMs of this call, once each


def _need(module: str):
    """The optional adapter dependency ``module`` (skipped when missing outside CI; CI has the dev extra)."""
    try:
        return __import__(module)
    except ImportError:
        if CI:
            raise
        pytest.skip(f"{module} is not installed")


def _batch_jobs(client, prob) -> int:
    """Server side: how many batch jobs stored the designs of ``prob``'s run (one per batch request)."""
    rows = client.run_evaluations(prob.run_id)["evaluations"]
    assert len(rows) == prob.n_evaluations
    return len({r["job_id"] for r in rows})


ADAPTER_POP = 6  # above the service's batch_sync_max (4): every generation is one 202 batch job


def test_optuna_ask_tell_one_batch_per_generation(client, wing) -> None:
    optuna = _need("optuna")
    from romams_client.optuna import OptunaBatch, constraints_func

    optuna.logging.set_verbosity(optuna.logging.WARNING)
    prob = FlutterProblem(client, wing, machs=[MACHS[-1]], mu=10.0, run="optuna-test")
    old = {} if hasattr(optuna.trial.Trial, "set_constraint") else {"constraints_func": constraints_func}
    sampler = optuna.samplers.NSGAIISampler(population_size=ADAPTER_POP, seed=3, **old)
    batch = OptunaBatch(prob, optuna.create_study(sampler=sampler))
    evs = [batch.step(ADAPTER_POP)]
    best = batch.optimize(generations=1, n=ADAPTER_POP)
    evs.append(prob.history[-1])
    assert prob.n_calls == 2 and _batch_jobs(client, prob) == 2  # one batch request per ask of n trials
    trials = batch.study.trials
    assert len(trials) == 2 * ADAPTER_POP and all(t.state == optuna.trial.TrialState.COMPLETE for t in trials)
    told = np.array([t.value for t in trials])
    assert told == pytest.approx(np.concatenate([e.objective for e in evs]), rel=1e-12)
    feasible = np.concatenate([e.feasible for e in evs])
    g = np.array([constraints_func(t) for t in trials])
    assert np.array_equal(np.all(g <= 0, axis=1), feasible)  # G <= 0 exactly for the feasible designs
    assert batch.best_history[1] <= batch.best_history[0] == pytest.approx(evs[0].objective.min(), rel=1e-12)
    assert best.value == pytest.approx(told.min(), rel=1e-12) and best.user_attrs["feasible"] == feasible[told.argmin()]
    if feasible.any():  # optuna's own best trial is the best feasible one
        assert batch.study.best_value == pytest.approx(told[feasible].min(), rel=1e-12)


def test_pymoo_vectorized_problem_one_batch_per_generation(client, wing) -> None:
    _need("pymoo")
    from pymoo.algorithms.soo.nonconvex.ga import GA
    from pymoo.optimize import minimize

    from romams_client.pymoo import FlutterPymooProblem

    prob = FlutterProblem(client, wing, machs=[MACHS[-1]], mu=10.0, run="pymoo-test")
    res = minimize(FlutterPymooProblem(prob), GA(pop_size=ADAPTER_POP, eliminate_duplicates=True), ("n_gen", 2),
                   seed=1, verbose=False)
    assert prob.n_calls == 2 and _batch_jobs(client, prob) == 2  # initial population + one offspring population
    assert [e.x.shape[0] for e in prob.history] == [ADAPTER_POP, ADAPTER_POP]
    first_best = prob.history[0].objective.min()
    everything = np.concatenate([e.objective for e in prob.history])
    assert res.F[0] <= first_best and res.F[0] == pytest.approx(everything.min(), rel=1e-12)


def test_openmdao_population_component_one_batch_per_generation(client, wing) -> None:
    om = _need("openmdao.api").api
    from romams_client.openmdao import FlutterPopulationComponent, PopulationDEDriver

    prob = FlutterProblem(client, wing, machs=[MACHS[-1]], mu=10.0, run="openmdao-test")
    model = om.Problem(reports=False)
    model.model.add_subsystem("flutter", FlutterPopulationComponent(problem=prob, pop_size=ADAPTER_POP),
                              promotes=["*"])
    model.model.add_design_var("X", lower=np.tile(prob.lower, (ADAPTER_POP, 1)),
                               upper=np.tile(prob.upper, (ADAPTER_POP, 1)))
    model.model.add_objective("objective")
    model.driver = PopulationDEDriver(max_gen=1, seed=2)
    model.setup()
    model.run_driver()
    drv = model.driver
    assert prob.n_calls == 2 and _batch_jobs(client, prob) == 2  # one request per generation, not per design
    assert drv.iter_count == 2 and len(drv.history) == 2
    gen0, gen1 = (e.objective for e in prob.history)
    assert drv.history[0] == pytest.approx(gen0.min(), rel=1e-12)
    assert drv.best_f <= drv.history[0] and drv.best_f == pytest.approx(min(gen0.min(), gen1.min()), rel=1e-12)
    assert model.get_val("objective") == pytest.approx(gen1, rel=1e-12)  # the model holds the last population
    assert np.all((drv.best_x >= prob.lower) & (drv.best_x <= prob.upper))
