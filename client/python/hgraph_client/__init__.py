"""Python client of the hgraph service (hgraph.v1.PathMerger).

    import hgraph_client
    with hgraph_client.connect("localhost:50051") as client:
        scene = client.upload_scene("scenes/circles/scene.json")
        client.create_session(scene)
        merged = client.merge(paths, measure="length", on_progress=print)
        # With a deadline: the best certified path streamed so far if the time runs out.
        quick = client.merge(paths, timeout=0.5, best_so_far=True)  # quick.complete: finished
        again = client.requery(merged.hgraph, measure="inverse-clearance")
        checked = client.check(paths)  # each path as a merge checks its inputs
        planned = client.plan(count=4)  # the paths found; planned.failures: why others were not
        solved = client.solve(budget_s=3)  # planners and merge in one call: solved.path

Install: `/usr/bin/python3 -m pip install ./client/python` (the hgraph.v1 stubs are generated
while it builds; README.md beside pyproject.toml). In a build tree, CMake also builds them into
<build>/python: put that folder and this one on PYTHONPATH.

A failed call raises HgraphError, whose `details` (`reason`, `field`, `retry_delay_s`) come
from the google.rpc.Status the server attaches (decode_error_details reads them from any
grpc.RpcError's trailing metadata).

Every call carries the session's name in `x-hgraph-session` (session affinity behind a load
balancer); merge, check and plan recover from a lost replica with retries and backoff (Client).
"""
from hgraph_client.client import (CheckOutcome, Client, HgraphError, MergeOutcome, PlanFailure,
                                  PlanOutcome, Progress, SolveOutcome, StopMerge, connect,
                                  load_paths_text,
                                  make_measure, make_paths)
from hgraph_client.status import ErrorDetails, decode as decode_error_details

__all__ = ["CheckOutcome", "Client", "ErrorDetails", "HgraphError", "MergeOutcome", "PlanFailure",
           "PlanOutcome", "SolveOutcome", "Progress", "StopMerge", "connect", "decode_error_details", "load_paths_text", "make_measure",
           "make_paths"]
