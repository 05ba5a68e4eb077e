"""Many flutter searches run together: one batched eigen-solve per sweep step across all of them.

A search is written as a generator (``analysis.flutter_search``, ``tracking.Tracker``, ``crossing``): where it
needs eigen-data it yields an ``eigen.EigRequest`` (sweep points of its model) or a ``newton.RootRequest`` (a
Newton root of det T(s)) and receives the answer. ``run_searches`` drives any number of such generators in
lockstep rounds: every round collects the one pending request of each search (eigen requests wait a few rounds while
other searches ask for Newton roots, so that they share calls), stacks all coupled matrices of
one size into a single ``numpy.linalg.eigvals`` / ``eig`` call and all Newton requests of one shape into one
batched Newton iteration, and sends each search its part. A search that needs extra refinement just takes more
rounds; the others finish and leave the batch. A single search is the batch of one (``run_one``), so the one-at-
a-time path and the batched path run the same algorithm on the same numbers.
"""

from __future__ import annotations

from collections.abc import Generator, Sequence
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np

from .eigen import EigData, EigRequest, eig_batch, struct_vectors
from .eigen import _tustin_matrices as tustin_matrices
from .newton import Request, RootRequest, RootsRequest, roots_and_vectors

T = TypeVar("T")


@dataclass
class SolveStats:
    """Counters of a run: full eigen-solves (matrices), batched LAPACK calls, Newton roots, rounds."""

    matrices: int = 0
    eig_calls: int = 0
    newton_roots: int = 0
    rounds: int = 0

    def reset(self) -> None:
        """All counters back to 0."""
        self.matrices = self.eig_calls = self.newton_roots = self.rounds = 0


STATS = SolveStats()  # process-wide counters (benchmarks read and reset them)


def _fast(r: EigRequest) -> bool:
    """True when the request takes the Tustin fast path (eigenvalues only, null vectors of T(s))."""
    return r.model.coupling == "tustin" and r.model.lam_a is not None


def _answer_eigs(reqs: Sequence[EigRequest]) -> list[EigData]:
    """Eigen-data of every request; the Tustin fast-path ones of one matrix size in one ``eigvals`` call."""
    out: list[EigData | None] = [None] * len(reqs)
    groups: dict[int, list[int]] = {}
    for i, r in enumerate(reqs):
        if _fast(r):
            groups.setdefault(r.model.k * 2 + r.model.na, []).append(i)
        else:  # reference path (defective aero matrix, zero-order hold): full eigenvectors, one request at a time
            out[i] = eig_batch(r.model, r.v, r.q, r.vectors)
            STATS.matrices += r.v.size
            STATS.eig_calls += 1
    for idx in groups.values():
        mats = np.concatenate([tustin_matrices(reqs[i].model, reqs[i].v, reqs[i].q) for i in idx])
        lam_all = np.linalg.eigvals(mats).astype(complex)
        STATS.matrices += mats.shape[0]
        STATS.eig_calls += 1
        start = 0
        for i in idx:
            r = reqs[i]
            lam = lam_all[start:start + r.v.size]
            start += r.v.size
            out[i] = _with_vectors(r, lam)
    return [e for e in out if e is not None]


def _with_vectors(r: EigRequest, lam: np.ndarray) -> EigData:
    """EigData of a fast-path request from its eigenvalues lam [n, nt] (null vectors of T(s) when asked for)."""
    per = np.full(r.v.size, np.inf)
    if not r.vectors:
        return EigData(lam, None, None, per)
    sv = struct_vectors(r.model, lam, r.v, r.q)
    if sv is None:  # ill-defined null vectors: the full eigenvectors of this request
        STATS.matrices += r.v.size
        STATS.eig_calls += 1
        return eig_batch(r.model, r.v, r.q, True)
    return EigData(lam, sv[0], sv[1], per, sv[2])


def _answer_roots(reqs: Sequence[RootRequest], want: np.ndarray) -> tuple[list[Any], list[Any]]:
    """Newton roots of every request, and ``newton.roots_and_vectors``' data where ``want`` [n] asks for it;
    requests of one shape (k modes, number of aero poles) iterated together."""
    roots: list[Any] = [None] * len(reqs)
    vecs: list[Any] = [None] * len(reqs)
    groups: dict[tuple[int, int, bool], list[int]] = {}
    for i, r in enumerate(reqs):
        groups.setdefault(_shape(r), []).append(i)
    for idx in groups.values():
        rs, vs = roots_and_vectors([reqs[i] for i in idx], want[idx])
        for i, s, v in zip(idx, rs, vs, strict=True):
            roots[i], vecs[i] = s, v
    STATS.newton_roots += len(reqs)
    return roots, vecs


def _shape(r: RootRequest) -> tuple[int, int, bool]:
    """Group key of Newton requests that are iterated together: (k, number of aero poles or states, diagonal)."""
    m = r.model
    return (m.k, m.lam_a.size if m.lam_a is not None else m.na, m.lam_a is not None)


def answer(reqs: Sequence[Request]) -> list[Any]:
    """The answers to one round of requests (EigData for an EigRequest, complex or None for a RootRequest, a list
    of those for a RootsRequest); all Newton roots of the round are iterated together."""
    eig_i = [i for i, r in enumerate(reqs) if isinstance(r, EigRequest)]
    out: list[Any] = [None] * len(reqs)
    if eig_i:
        for i, e in zip(eig_i, _answer_eigs([reqs[i] for i in eig_i]), strict=True):  # type: ignore[misc]
            out[i] = e
    flat: list[RootRequest] = []
    owners: list[tuple[int, int]] = []  # (request index, number of roots; -1: a single RootRequest)
    for i, r in enumerate(reqs):
        if isinstance(r, RootRequest):
            flat.append(r)
            owners.append((i, -1))
        elif isinstance(r, RootsRequest):
            flat.extend(r.reqs)
            owners.append((i, len(r.reqs)))
    if flat:
        want = np.zeros(len(flat), bool)  # the roots of a RootsRequest come with their vectors
        pos = 0
        for _, n in owners:
            want[pos:pos + n] = n > 0
            pos += 1 if n < 0 else n
        roots, vecs = _answer_roots(flat, want)
        pos = 0
        for i, n in owners:
            out[i] = roots[pos] if n < 0 else (roots[pos:pos + n], vecs[pos:pos + n])
            pos += 1 if n < 0 else n
    STATS.rounds += 1
    return out


def run_searches(gens: Sequence[Generator[Request, Any, T]]) -> list[T]:
    """Drive the search generators to their ends in lockstep rounds (module docstring); their return values."""
    results: list[Any] = [None] * len(gens)
    pending: dict[int, Request] = {}
    for i, g in enumerate(gens):
        _advance(g, i, None, pending, results, first=True)
    waited: dict[int, int] = {}
    while pending:
        idx = _round(pending, waited)
        for i, a in zip(idx, answer([pending[i] for i in idx]), strict=True):
            _advance(gens[i], i, a, pending, results)
    return results


EIG_WAIT = 6  # rounds an eigen request may wait for others (while Newton requests are answered)


def _round(pending: dict[int, Request], waited: dict[int, int]) -> list[int]:
    """The searches answered in the next round: all, when every search asks for an eigen-solve, half of them do,
    or one has waited ``EIG_WAIT`` rounds; else only those asking for Newton roots (the eigen requests wait).

    Waiting lets the searches' full eigen-solves share LAPACK calls; an answer does not depend on the round it is
    given in, so the results do not change.
    """
    eig = [i for i, r in pending.items() if isinstance(r, EigRequest)]
    for i in list(waited):
        if i not in pending or not isinstance(pending[i], EigRequest):
            del waited[i]
    if 2 * len(eig) >= len(pending) or any(waited.get(i, 0) >= EIG_WAIT for i in eig):
        waited.clear()
        return list(pending)
    for i in eig:
        waited[i] = waited.get(i, 0) + 1
    return [i for i in pending if i not in waited]


def _advance(g: Generator[Request, Any, Any], i: int, value: Any, pending: dict[int, Request],
             results: list[Any], first: bool = False) -> None:
    """Send ``value`` to search i; store its next request in ``pending`` or its result when it has finished."""
    try:
        pending[i] = next(g) if first else g.send(value)
    except StopIteration as stop:
        pending.pop(i, None)
        results[i] = stop.value


def run_one(gen: Generator[Request, Any, T]) -> T:
    """Drive one search generator (the batch of one)."""
    return run_searches([gen])[0]
