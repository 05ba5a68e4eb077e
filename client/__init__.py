"""Python client of the romams flutter service, for remote optimizers (imports httpx, tqdm, numpy only).

    from client import RomamsClient, FlutterProblem
    with RomamsClient("http://127.0.0.1:8000") as c:
        wing = c.ensure_wing("cd", "cropped-delta")
        problem = FlutterProblem(c, wing)
        f = problem(X)            # X [pop, d] -> penalty objective [pop], one batch request
"""

from client.errors import JobError, JobTimeout, RomamsError
from client.http import RomamsClient
from client.problem import BatchEvaluation, FlutterProblem

__all__ = ["BatchEvaluation", "FlutterProblem", "JobError", "JobTimeout", "RomamsClient", "RomamsError"]
