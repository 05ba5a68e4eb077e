"""Python client of the romams flutter service, for remote optimizers (imports httpx, tqdm, numpy only).

    from romams_client import RomamsClient, FlutterProblem
    with RomamsClient("http://127.0.0.1:8000") as c:
        wing = c.ensure_wing("cd", "cropped-delta")
        problem = FlutterProblem(c, wing)
        f = problem(X)            # X [pop, d] -> penalty objective [pop], one batch request
"""

from romams_client.errors import JobError, JobTimeout, RomamsError
from romams_client.http import RomamsClient
from romams_client.problem import BatchEvaluation, FlutterProblem

__all__ = ["BatchEvaluation", "FlutterProblem", "JobError", "JobTimeout", "RomamsClient", "RomamsError"]
