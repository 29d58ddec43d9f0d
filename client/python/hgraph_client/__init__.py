"""Python client of the hgraph service (hgraph.v1.PathMerger).

    import hgraph_client
    with hgraph_client.connect("localhost:50051") as client:
        scene = client.upload_scene("scenes/circles/scene.json")
        client.create_session(scene)
        merged = client.merge(paths, measure="length", on_progress=print)
        again = client.requery(merged.hgraph, measure="inverse-clearance")
        checked = client.check(paths)  # each path as a merge checks its inputs

The generated modules (hgraph.v1.*_pb2, *_pb2_grpc) are built by CMake into
<build>/python; put that folder and this one on PYTHONPATH.
"""
from hgraph_client.client import (CheckOutcome, Client, HgraphError, MergeOutcome, Progress,
                                  connect, load_paths_text, make_measure, make_paths)

__all__ = ["CheckOutcome", "Client", "HgraphError", "MergeOutcome", "Progress", "connect",
           "load_paths_text", "make_measure", "make_paths"]
