"""A small typed wrapper over the generated hgraph.v1 stubs."""
from __future__ import annotations

import dataclasses
import hashlib
import os
import pathlib
import secrets
import time
from typing import Callable, Iterable, Iterator, Optional, Sequence, Union

import grpc
from google.protobuf import json_format

from hgraph.v1 import merge_pb2, path_pb2, scene_pb2, service_pb2, service_pb2_grpc, space_pb2
from hgraph_client import status as rich_status

# Uploads are chunked well below gRPC's default 4 MiB message limit.
CHUNK_BYTES = 1 << 20

# The request metadata a load balancer hashes on to keep a session on one replica (deploy/).
SESSION_METADATA = "x-hgraph-session"

# The bearer token's environment variable (the `token` argument wins), as for the CLI.
TOKEN_ENV = "HGRAPH_TOKEN"

PemSource = Union[str, pathlib.Path, bytes, None]

# Codes after which a session call is worth repeating on a fresh session: the replica that held
# the session is gone (UNAVAILABLE), or the call reached a replica that never saw it (NOT_FOUND
# for the session, its scene or a blob: not for an H-Graph, which a new session does not have).
RECOVERABLE = (grpc.StatusCode.UNAVAILABLE, grpc.StatusCode.NOT_FOUND)
RECOVERABLE_REASONS = (None, "SESSION_NOT_FOUND", "SCENE_NOT_FOUND", "BLOB_NOT_FOUND")

MEASURES = {
    "length": merge_pb2.Measure.TYPE_LENGTH,
    "inverse-clearance": merge_pb2.Measure.TYPE_INVERSE_CLEARANCE,
    "bottleneck-clearance": merge_pb2.Measure.TYPE_BOTTLENECK_CLEARANCE,
    "safe-length": merge_pb2.Measure.TYPE_SAFE_LENGTH,
}

VARIANTS = {
    "all-pairs": merge_pb2.VARIANT_ALL_PAIRS,
    "neighborhood": merge_pb2.VARIANT_NEIGHBORHOOD,
    "k-nearest": merge_pb2.VARIANT_K_NEAREST,
    "edit-distance": merge_pb2.VARIANT_EDIT_DISTANCE,
    "edit-distance-neighborhood": merge_pb2.VARIANT_EDIT_DISTANCE_NEIGHBORHOOD,
}

EVALUATIONS = {
    "lazy": merge_pb2.EVALUATION_LAZY,
    "eager": merge_pb2.EVALUATION_EAGER,
}

# MergeOptions.check_mode: "certified" (the default) proves every motion of the merged path free;
# "sampled" checks it at the resolution's samples only, as OMPL's DiscreteMotionValidator does
# (MergeResult.certified False).
CHECK_MODES = {
    "certified": merge_pb2.CHECK_MODE_CERTIFIED,
    "sampled": merge_pb2.CHECK_MODE_SAMPLED,
}


class HgraphError(Exception):
    """A failed call: the canonical gRPC code, the server's message (which names the field) and
    its error details (hgraph_client.status.ErrorDetails; None from an older server or from gRPC
    itself): `reason` ("SESSION_NOT_FOUND", "SERVER_BUSY", ...), `field` (the offending field)
    and `retry_delay_s` (set when the same call is worth retrying after that long)."""

    def __init__(self, code: grpc.StatusCode, message: str,
                 details: Optional[rich_status.ErrorDetails] = None, local: bool = False):
        super().__init__(f"{code.name}: {message}")
        self.code = code
        self.message = message
        self.details = details
        # True when this client made the error itself (it stopped the call), not the server or
        # the network.
        self.local = local

    @property
    def transient(self) -> bool:
        """Whether the same call is worth repeating as it is: the replica could not be reached
        (UNAVAILABLE: it is restarting, or the balancer found none for a moment), or the call was
        reset on its way (CANCELLED by a proxy, or by a replica shutting down, not by this
        client)."""
        return (self.code == grpc.StatusCode.UNAVAILABLE or
                (self.code == grpc.StatusCode.CANCELLED and not self.local))

    @property
    def reason(self) -> Optional[str]:
        return self.details.reason if self.details else None

    @property
    def field(self) -> Optional[str]:
        return (self.details.metadata or {}).get("field") if self.details else None

    @property
    def retry_delay_s(self) -> Optional[float]:
        return self.details.retry_delay_s if self.details else None


class StopMerge(Exception):
    """Raised by a merge's on_progress callback to end the call at once (Client.merge)."""


@dataclasses.dataclass
class Progress:
    phase: str
    done: int
    total: int
    collision_checks: int
    distance_queries: int
    elapsed_ms: float
    # Phase "optimize": the best path's objective so far (round 0: the H-Graph's optimum), and
    # with progress_paths the path itself (certified); None otherwise.
    objective: Optional[float] = None
    path: Optional[path_pb2.Path] = None


@dataclasses.dataclass
class MergeOutcome:
    result: merge_pb2.MergeResult
    # "sessions/<id>/hgraphs/<hgraph id>": pass to Client.requery. Empty if the server did not
    # keep it (`retention` says why).
    hgraph: str
    progress_events: int
    # False when the call stopped early (best_so_far and the deadline, or StopMerge) and `result`
    # holds the best path streamed so far: its path, objective, measure and (when its event was
    # received) hgraph_objective only, no report; the path is certified all the same (unless
    # the merge asked for check="sampled": result.certified says which).
    complete: bool = True
    # The H-Graph's generation (1 after a merge; AddPaths increments it); 0 when not kept.
    generation: int = 0
    # service_pb2.RETENTION_*: KEPT, or why the H-Graph was not kept (TOO_LARGE for
    # --cache-bytes, SESSION_ENDED when the session went away while the merge ran);
    # UNSPECIFIED when the call stopped early (complete False) or the server predates it.
    retention: int = service_pb2.RETENTION_UNSPECIFIED
    # True when the server wrote the H-Graph to its shared store (hgraph-server --store
    # redis://...) before answering: any replica answers requery and add_paths on it. False
    # when one replica alone holds it (no shared store, or the store was down).
    shared: bool = False

    @property
    def kept(self) -> bool:
        """Whether the server holds the H-Graph for requery, add_paths and get_hgraph."""
        return self.retention == service_pb2.RETENTION_KEPT


@dataclasses.dataclass
class PlanFailure:
    # The attempt's index in the request's count, its planning time, and why it found no path
    # (service_pb2.PlanAttemptFailure: reason, planner, seed, message, invalid_edge).
    index: int
    elapsed_ms: float
    failure: service_pb2.PlanAttemptFailure


class PlanOutcome(list):
    """The paths PlanPaths found (path_pb2.Path, in index order), as a list; `failures` holds a
    PlanFailure for each attempt that found none."""

    def __init__(self, paths=()):
        super().__init__(paths)
        self.failures: list = []


@dataclasses.dataclass
class SolveOutcome:
    # service_pb2.SolveResult: found, message (why not found), merge (the best path and its
    # report, as a merge's result), runs (every planner run), plan_ms, elapsed_ms, budget_s,
    # most_runs_at_once (planner runs at once on the worker pool), runs_on_call_worker.
    result: service_pb2.SolveResult
    # "sessions/<id>/hgraphs/<hgraph id>" of the H-Graph of every path found: pass it to
    # requery, add_paths, get_hgraph. Empty when no path was found or it was not kept.
    hgraph: str
    # The progress events (service_pb2.SolveProgress): one per ended run (`run` set) and one per
    # improvement of the best certified path (`objective` and `path` set), in arrival order.
    progress: list
    generation: int = 0
    retention: int = service_pb2.RETENTION_UNSPECIFIED

    @property
    def found(self) -> bool:
        return self.result.found

    @property
    def kept(self) -> bool:
        """Whether the server holds the H-Graph for requery, add_paths and get_hgraph."""
        return self.retention == service_pb2.RETENTION_KEPT

    @property
    def path(self) -> Optional[path_pb2.Path]:
        """The best certified path, or None when none was found."""
        return self.result.merge.path if self.result.found else None


@dataclasses.dataclass
class CheckOutcome:
    # One report per path, in request order: valid, invalid_edge, invalid_at, invalid_cause,
    # invalid_reason, certified, waypoints and quality (length, min/avg/inverse clearance).
    paths: list
    collision_checks: int
    distance_queries: int
    resolution: float
    elapsed_ms: float

    @property
    def valid(self) -> bool:
        """True when every path is valid."""
        return all(p.valid for p in self.paths)


PathLike = Union[path_pb2.Path, Sequence[Sequence[float]]]


def make_measure(measure: Union[str, merge_pb2.Measure], k: Optional[float] = None,
                 safety: Optional[float] = None) -> merge_pb2.Measure:
    """"length", "inverse-clearance", "bottleneck-clearance", "safe-length", or a Measure."""
    if isinstance(measure, merge_pb2.Measure):
        return measure
    if measure not in MEASURES:
        raise ValueError(f"measure: unknown {measure!r}; known: {', '.join(MEASURES)}")
    proto = merge_pb2.Measure(type=MEASURES[measure])
    if k is not None:
        proto.k = k
    if safety is not None:
        proto.safety = safety
    return proto


def make_paths(paths: Union[path_pb2.PathSet, Iterable[PathLike]]) -> path_pb2.PathSet:
    """A PathSet from Path messages or from lists of waypoints (each a list of numbers)."""
    if isinstance(paths, path_pb2.PathSet):
        return paths
    out = path_pb2.PathSet()
    for i, path in enumerate(paths):
        if isinstance(path, path_pb2.Path):
            out.paths.append(path)
            continue
        p = out.paths.add(name=f"path{i}")
        for q in path:
            p.waypoints.add(values=[float(v) for v in q])
    return out


def load_paths_text(text: str) -> path_pb2.PathSet:
    """OMPL's matrix format: one configuration per line, blank lines between paths, '#' comments."""
    paths, current = [], []
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if not line:
            if current:
                paths.append(current)
                current = []
            continue
        current.append([float(v) for v in line.split()])
    if current:
        paths.append(current)
    return make_paths(paths)


def _digest(data: bytes) -> scene_pb2.Digest:
    return scene_pb2.Digest(sha256=hashlib.sha256(data).hexdigest(), size_bytes=len(data))


def _pem(source: PemSource, name: str) -> Optional[bytes]:
    """PEM bytes given as such, or read from a file path."""
    if source is None or isinstance(source, bytes):
        return source
    try:
        return pathlib.Path(source).read_bytes()
    except OSError as e:
        raise ValueError(f"{name}: cannot read {source}: {e.strerror}") from None


def _raise(error: grpc.RpcError) -> None:
    trailing = error.trailing_metadata() if hasattr(error, "trailing_metadata") else None
    raise HgraphError(error.code(), error.details(), rich_status.decode(trailing)) from None


class Client:
    """One channel to an hgraph server, or to a load balancer in front of several replicas.
    Not thread safe (holds the current session).

    Session affinity: the client names its session before it exists ("sessions/<128 random
    bits>", `session_name`; CreateSessionRequest.session_id) and sends that name in the
    `x-hgraph-session` metadata of every call, from the first upload on, so that a balancer
    hashing on it (deploy/base/nginx/hgraph.conf) sends the scene, the session and every later
    call to the same replica.

    Recovery: when a merge, check or plan fails with UNAVAILABLE or NOT_FOUND (the replica was
    lost, and the balancer now sends the session's calls to another one), the client waits
    (exponential backoff: `backoff_s`, doubled each attempt, at most `retries` attempts),
    uploads the scene again (only the blobs the new replica lacks), re-creates the session under
    the same name and repeats the call. Without a shared store, H-Graphs of the lost session are
    gone: a requery on one raises NOT_FOUND; merge again. With one (hgraph-server --store
    redis://...), another replica loads the session and its H-Graphs and no recovery is needed.
    `retries=0` turns recovery off. Requery, get_session, get_hgraph, list_sessions and add_paths
    with a request_id are repeated as they are after a transient error (UNAVAILABLE, or a reset
    on the way: HgraphError.transient), as often and with the same backoff.

    Security: `tls_ca` (the PEM CA that signed the server's certificate; a path or the bytes)
    turns TLS on; without it but with a client certificate the system's roots are trusted.
    `tls_cert` and `tls_key` are the client certificate and its key for a server that requires
    mutual TLS (--tls-client-ca). `token` (default: $HGRAPH_TOKEN) goes with every call as
    `authorization: Bearer <token>` for a server with --auth-tokens; sessions then belong to the
    token's tenant (token="" sends none, whatever the environment says). Over plaintext the
    token travels in the clear: use it with TLS (or on loopback).
    """

    def __init__(self, target: str, *, max_message_bytes: int = 64 << 20, retries: int = 4,
                 backoff_s: float = 0.2, tls_ca: PemSource = None, tls_cert: PemSource = None,
                 tls_key: PemSource = None, token: Optional[str] = None):
        self.target = target
        options = [
            ("grpc.max_receive_message_length", max_message_bytes),
            ("grpc.max_send_message_length", max_message_bytes),
        ]
        if (tls_cert is None) != (tls_key is None):
            raise ValueError("tls_cert and tls_key go together (the client certificate of "
                             "mutual TLS and its private key)")
        if tls_ca is not None or tls_cert is not None:
            credentials = grpc.ssl_channel_credentials(
                root_certificates=_pem(tls_ca, "tls_ca"),
                private_key=_pem(tls_key, "tls_key"),
                certificate_chain=_pem(tls_cert, "tls_cert"))
            self.channel = grpc.secure_channel(target, credentials, options=options)
        else:
            self.channel = grpc.insecure_channel(target, options=options)
        # None: from the environment; "" sends no token even when the variable is set.
        if token is None:
            token = os.environ.get(TOKEN_ENV, "")
        if any(c <= " " or c > "~" for c in token):
            raise ValueError("token: must be visible ASCII characters without blanks")
        self._auth = (("authorization", "Bearer " + token),) if token else ()
        self.stub = service_pb2_grpc.PathMergerStub(self.channel)
        self.session: Optional[str] = None
        self.session_name = "sessions/" + secrets.token_hex(16)
        self.retries = retries
        self.backoff_s = backoff_s
        self.recoveries = 0  # sessions re-created after a lost replica
        self.repeats = 0  # calls repeated as they were after a transient error
        self._scene: Optional[tuple] = None  # (scene, base_dir) of the last upload_scene

    def _metadata(self, name: Optional[str] = None) -> tuple:
        return ((SESSION_METADATA, name or self.session or self.session_name),) + self._auth

    def _recovering(self, call: Callable[[], object], explicit_session: Optional[str]):
        """Runs call(); on a recoverable error restores the current session and runs it again;
        after a call reset on its way (CANCELLED, HgraphError.transient) runs it again as it
        is."""
        attempt = 0
        while True:
            try:
                return call()
            except HgraphError as e:
                if e.code == grpc.StatusCode.CANCELLED and e.transient and \
                        attempt < self.retries:
                    time.sleep(self.backoff_s * (2 ** attempt))
                    attempt += 1
                    self.repeats += 1
                    continue
                if (e.code not in RECOVERABLE or e.reason not in RECOVERABLE_REASONS or
                        attempt >= self.retries or
                        explicit_session not in (None, self.session) or self._scene is None or
                        self.session is None):
                    raise
            time.sleep(self.backoff_s * (2 ** attempt))
            attempt += 1
            try:
                self._restore_session()
            except HgraphError as e:
                if e.code not in RECOVERABLE or attempt >= self.retries:
                    raise

    def _retrying(self, call: Callable[[], object]):
        """Runs call(), a call safe to repeat; after a transient error (HgraphError.transient)
        runs it again, with the same backoff and at most `retries` times. With a shared store
        another replica then answers for the session and its H-Graphs."""
        attempt = 0
        while True:
            try:
                return call()
            except HgraphError as e:
                if not e.transient or attempt >= self.retries:
                    raise
            time.sleep(self.backoff_s * (2 ** attempt))
            attempt += 1
            self.repeats += 1

    def _restore_session(self) -> None:
        scene, base_dir = self._scene
        digest = self.upload_scene(scene, base_dir)
        self.create_session(digest, session_id=self.session.split("/", 1)[1])
        self.recoveries += 1

    def close(self) -> None:
        self.channel.close()

    def __enter__(self) -> "Client":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # Blobs and scenes -------------------------------------------------------------------------

    def upload_blob(self, data: bytes, timeout: Optional[float] = None) -> scene_pb2.Digest:
        digest = _digest(data)

        def chunks() -> Iterator[service_pb2.UploadBlobRequest]:
            yield service_pb2.UploadBlobRequest(digest=digest, data=data[:CHUNK_BYTES])
            for at in range(CHUNK_BYTES, len(data), CHUNK_BYTES):
                yield service_pb2.UploadBlobRequest(data=data[at:at + CHUNK_BYTES])

        try:
            self.stub.UploadBlob(chunks(), timeout=timeout, metadata=self._metadata())
        except grpc.RpcError as e:
            _raise(e)
        return digest

    def upload_scene(self, scene: Union[str, pathlib.Path, scene_pb2.Scene],
                     base_dir: Union[str, pathlib.Path, None] = None,
                     timeout: Optional[float] = None) -> scene_pb2.Digest:
        """Stores a scene (a JSON file or a Scene message) and returns its digest.

        Meshes given by file path (relative to the scene file's folder, or `base_dir`) are
        replaced by their digests; only the blobs the server lacks are uploaded.
        """
        self._scene = (scene, base_dir)
        if isinstance(scene, scene_pb2.Scene):
            proto = scene_pb2.Scene()
            proto.CopyFrom(scene)
            folder = pathlib.Path(base_dir or ".")
        else:
            path = pathlib.Path(scene)
            proto = json_format.Parse(path.read_text(), scene_pb2.Scene())
            folder = pathlib.Path(base_dir) if base_dir else path.parent
        blobs = {}
        shapes = [o.shape for o in proto.obstacles] + [b.shape for b in proto.robot]
        for shape in shapes:
            if shape.HasField("mesh") and shape.mesh.WhichOneof("source") == "path":
                data = (folder / shape.mesh.path).read_bytes()
                digest = _digest(data)
                blobs[digest.sha256] = (digest, data)
                if not shape.mesh.format:
                    shape.mesh.format = pathlib.Path(shape.mesh.path).suffix.lstrip(".")
                shape.mesh.digest.CopyFrom(digest)
        try:
            if blobs:
                missing = self.stub.FindMissingBlobs(service_pb2.FindMissingBlobsRequest(
                    digests=[d for d, _ in blobs.values()]), timeout=timeout,
                    metadata=self._metadata()).missing
                for digest in missing:
                    self.upload_blob(blobs[digest.sha256][1], timeout=timeout)
            return self.stub.PutScene(service_pb2.PutSceneRequest(scene=proto),
                                      timeout=timeout, metadata=self._metadata()).digest
        except grpc.RpcError as e:
            _raise(e)

    # Sessions ---------------------------------------------------------------------------------

    def create_session(self, scene: scene_pb2.Digest, timeout: Optional[float] = None,
                       session_id: Optional[str] = None) -> service_pb2.Session:
        """Creates a session on the scene and makes it the client's current session.

        Its name is `session_name` (chosen by the client; a later create_session chooses a new
        one), or "sessions/<session_id>"."""
        if session_id is None:
            if self.session is not None:
                self.session_name = "sessions/" + secrets.token_hex(16)
            session_id = self.session_name.split("/", 1)[1]
        name = "sessions/" + session_id
        request = service_pb2.CreateSessionRequest(scene=scene, session_id=session_id)
        try:
            try:
                session = self.stub.CreateSession(request, timeout=timeout,
                                                  metadata=self._metadata(name))
            except grpc.RpcError as e:
                # A new name may hash to a replica that has not seen the scene: store it there.
                if e.code() != grpc.StatusCode.NOT_FOUND or self._scene is None:
                    raise
                self.session, previous = None, self.session
                self.session_name = name
                try:
                    self.upload_scene(*self._scene, timeout=timeout)
                finally:
                    self.session = previous
                session = self.stub.CreateSession(request, timeout=timeout,
                                                  metadata=self._metadata(name))
        except grpc.RpcError as e:
            _raise(e)
        self.session = self.session_name = session.name
        return session

    def get_session(self, name: Optional[str] = None) -> service_pb2.Session:
        def call():
            try:
                return self.stub.GetSession(
                    service_pb2.GetSessionRequest(name=name or self.session),
                    metadata=self._metadata(name))
            except grpc.RpcError as e:
                _raise(e)

        return self._retrying(call)

    def list_sessions(self, page_size: int = 0) -> list:
        """This tenant's sessions (every page of ListSessions): those of every replica when the
        replicas share a store (--store redis://...), else those of the replica that answers."""
        out, token = [], ""

        def page_after(token):
            try:
                return self.stub.ListSessions(
                    service_pb2.ListSessionsRequest(page_size=page_size, page_token=token),
                    metadata=self._metadata())
            except grpc.RpcError as e:
                _raise(e)

        while True:
            page = self._retrying(lambda: page_after(token))
            out.extend(page.sessions)
            token = page.next_page_token
            if not token:
                return out

    def get_hgraph(self, name: str) -> service_pb2.HGraph:
        """A kept H-Graph (GetHGraph): generation, inputs, size and the merge's result; state
        RUNNING while a merge with an hgraph_id still builds it."""
        def call():
            try:
                return self.stub.GetHGraph(service_pb2.GetHGraphRequest(name=name),
                                           metadata=self._metadata(name.split("/hgraphs/", 1)[0]))
            except grpc.RpcError as e:
                _raise(e)

        return self._retrying(call)

    def delete_hgraph(self, name: str) -> None:
        try:
            self.stub.DeleteHGraph(service_pb2.DeleteHGraphRequest(name=name),
                                   metadata=self._metadata(name.split("/hgraphs/", 1)[0]))
        except grpc.RpcError as e:
            _raise(e)

    def delete_session(self, name: Optional[str] = None) -> None:
        try:
            self.stub.DeleteSession(service_pb2.DeleteSessionRequest(name=name or self.session),
                                    metadata=self._metadata(name))
        except grpc.RpcError as e:
            _raise(e)

    # Merging ----------------------------------------------------------------------------------

    def merge(self, paths, *, measure: Union[str, merge_pb2.Measure] = "length",
              k: Optional[float] = None, safety: Optional[float] = None,
              variant: Optional[str] = None, options: Optional[merge_pb2.MergeOptions] = None,
              max_node_spacing: Optional[float] = None,
              evaluation: Optional[str] = None, report_inputs: Optional[bool] = None,
              report_clearance: Optional[bool] = None, check: Optional[str] = None,
              optimize_ms: Optional[float] = None, restarts: Optional[int] = None,
              partial_shortcuts: Optional[bool] = None,
              progress_paths: Optional[bool] = None, best_so_far: bool = False,
              optimize_to_deadline: bool = False, deadline_margin_ms: Optional[float] = None,
              session: Optional[str] = None,
              on_progress: Optional[Callable[[Progress], None]] = None,
              progress_interval_ms: int = 0, seed: int = 0, hgraph_id: str = "",
              timeout: Optional[float] = None) -> MergeOutcome:
        """Merges the paths in the session (default: the current one), streaming progress.

        `max_node_spacing` subdivides long input edges in the H-Graph so that bridges can leave
        an input mid-edge (MergeOptions.max_node_spacing). `evaluation` is "lazy" (the default:
        only the edges the search wants are checked) or "eager"; `report_inputs` checks every
        input edge so that every input report is complete (InputReport.checked); `check` is
        "certified" (the default: every motion of the merged path proven free) or "sampled"
        (checked at the resolution's samples only, as OMPL's DiscreteMotionValidator: cheaper,
        may miss a collision between two samples; result.certified is False);
        `report_clearance` profiles the merged path's clearance under length (otherwise its
        quality has the length only, PathQuality.has_clearance False); `optimize_ms`
        bounds the post-optimization (0 = off; unset = automatic; a budget given is spent on
        restarts from the inputs once its rounds stop gaining); `restarts` sets how many
        (MergeOptions.optimize_restarts: each about one post-optimization, the same result on
        every machine within the budget); `partial_shortcuts` lets a
        quarter of its shortcuts move one part of the configuration alone (~1% shorter paths for
        ~18% more checks).

        The post-optimization streams the best path's objective (Progress.objective), and with
        `progress_paths` the path itself (Progress.path, certified). `best_so_far` (which asks
        for the paths) makes a call whose `timeout` passes after the first of them return that
        best path (MergeOutcome.complete False) instead of raising DEADLINE_EXCEEDED. An
        on_progress callback may raise StopMerge to end the call at once: the merge then returns
        the best path streamed so far, or raises HgraphError(CANCELLED) if none came yet.

        `optimize_to_deadline` spends what is left of `timeout` on the post-optimization and
        still answers with a complete result before it (MergeOptions.optimize_to_deadline;
        result.stats.optimize_stop says OPTIMIZE_STOP_DEADLINE when the time ran out), keeping
        `deadline_margin_ms` back for the answer (unset: a tenth of the time, at least 50 ms).

        `hgraph_id` names the H-Graph ("sessions/<id>/hgraphs/<hgraph_id>"): a repeat of the same
        call returns the first merge's result, and the merge finishes (and is kept) even if
        this call ends first: get_hgraph(name) then returns its result."""
        return self._recovering(lambda: self._merge(
            paths, measure=measure, k=k, safety=safety, variant=variant, options=options,
            max_node_spacing=max_node_spacing, evaluation=evaluation,
            report_inputs=report_inputs, report_clearance=report_clearance, check=check,
            optimize_ms=optimize_ms, restarts=restarts,
            partial_shortcuts=partial_shortcuts, progress_paths=progress_paths,
            best_so_far=best_so_far, optimize_to_deadline=optimize_to_deadline,
            deadline_margin_ms=deadline_margin_ms, session=session, on_progress=on_progress,
            progress_interval_ms=progress_interval_ms, seed=seed, hgraph_id=hgraph_id,
            timeout=timeout), session)

    def _merge(self, paths, *, measure, k, safety, variant, options, max_node_spacing,
               evaluation, report_inputs, report_clearance, check, optimize_ms, restarts,
               partial_shortcuts, progress_paths, best_so_far, optimize_to_deadline,
               deadline_margin_ms, session, on_progress, progress_interval_ms, seed, hgraph_id,
               timeout) -> MergeOutcome:
        opts = merge_pb2.MergeOptions()
        if options is not None:
            opts.CopyFrom(options)
        if variant is not None:
            opts.variant = VARIANTS[variant]
        if max_node_spacing is not None:
            opts.max_node_spacing = max_node_spacing
        if evaluation is not None:
            opts.evaluation = EVALUATIONS[evaluation]
        if check is not None:
            if check not in CHECK_MODES:
                raise ValueError(f"check: unknown check mode {check!r} (expected "
                                 f"{' or '.join(CHECK_MODES)})")
            opts.check_mode = CHECK_MODES[check]
        if report_inputs is not None:
            opts.report_inputs = report_inputs
        if report_clearance is not None:
            opts.report_clearance = report_clearance
        if optimize_ms is not None:
            opts.optimize_ms = optimize_ms
        if restarts is not None:
            opts.optimize_restarts = restarts
        if partial_shortcuts is not None:
            opts.partial_shortcuts = partial_shortcuts
        if progress_paths is not None:
            opts.progress_paths = progress_paths
        if best_so_far:
            opts.progress_paths = True
        if optimize_to_deadline:
            opts.optimize_to_deadline = True
        if deadline_margin_ms is not None:
            opts.deadline_margin_ms = deadline_margin_ms
        request = service_pb2.MergePathsRequest(
            session=session or self.session or "", paths=make_paths(paths),
            measure=make_measure(measure, k, safety), options=opts, seed=seed,
            progress_interval_ms=progress_interval_ms, hgraph_id=hgraph_id)
        events = 0
        # The best path streamed so far, as a result of its own (path, objectives, measure).
        best: Optional[merge_pb2.MergeResult] = None
        call = self.stub.MergePaths(request, timeout=timeout,
                                    metadata=self._metadata(request.session))
        try:
            for event in call:
                if event.HasField("progress"):
                    events += 1
                    p = event.progress
                    objective = p.objective if p.HasField("objective") else None
                    path = p.path if p.HasField("path") else None
                    if path is not None:
                        if best is None:
                            sampled = opts.check_mode == merge_pb2.CHECK_MODE_SAMPLED
                            best = merge_pb2.MergeResult(
                                measure=request.measure,
                                check_mode=(merge_pb2.CHECK_MODE_SAMPLED if sampled
                                            else merge_pb2.CHECK_MODE_CERTIFIED),
                                certified=not sampled)
                        if p.done == 0:
                            best.hgraph_objective = objective
                        best.path.CopyFrom(path)
                        best.objective = objective
                    if on_progress is not None:
                        on_progress(Progress(p.phase, p.done, p.total, p.collision_checks,
                                             p.distance_queries, p.elapsed_ms, objective, path))
                elif event.HasField("result"):
                    return MergeOutcome(event.result, event.hgraph, events,
                                        generation=event.generation,
                                        retention=event.retention, shared=event.shared)
        except StopMerge:
            call.cancel()
            if best is None:
                raise HgraphError(grpc.StatusCode.CANCELLED,
                                  "stopped by on_progress before a path was streamed "
                                  "(progress_paths)", local=True) from None
            return MergeOutcome(best, "", events, complete=False)
        except grpc.RpcError as e:
            if (best_so_far and best is not None and
                    e.code() == grpc.StatusCode.DEADLINE_EXCEEDED):
                return MergeOutcome(best, "", events, complete=False)
            _raise(e)
        raise HgraphError(grpc.StatusCode.INTERNAL, "the stream ended without a result")

    def merge_stream(self, request: service_pb2.MergePathsRequest,
                     timeout: Optional[float] = None):
        """The raw response stream (a grpc call object: iterate it, or .cancel() it)."""
        return self.stub.MergePaths(request, timeout=timeout,
                                    metadata=self._metadata(request.session))

    def requery(self, hgraph: str, measure: Union[str, merge_pb2.Measure] = "length", *,
                k: Optional[float] = None, safety: Optional[float] = None,
                report_clearance: Optional[bool] = None,
                timeout: Optional[float] = None) -> merge_pb2.MergeResult:
        """Searches a stored H-Graph under another measure, reusing its checked edges.

        `report_clearance` profiles the path's clearance under length for this query (None: as
        the merge that built the H-Graph asked). Repeated after a transient error
        (HgraphError.transient), as `retries` says."""
        request = service_pb2.RequeryRequest(
            hgraph=hgraph, measure=make_measure(measure, k, safety),
            report_clearance=report_clearance)

        def call():
            try:
                return self.stub.Requery(
                    request, timeout=timeout,
                    metadata=self._metadata(hgraph.split("/hgraphs/", 1)[0])).result
            except grpc.RpcError as e:
                _raise(e)

        return self._retrying(call)

    def add_paths(self, hgraph: str, paths, measure: Union[str, merge_pb2.Measure] = "length", *,
                  k: Optional[float] = None, safety: Optional[float] = None,
                  report_clearance: Optional[bool] = None, request_id: str = "",
                  expected_generation: Optional[int] = None,
                  timeout: Optional[float] = None) -> service_pb2.AddPathsResponse:
        """Adds input paths to a stored H-Graph (edges checked before are kept), then searches
        it under `measure` (AddPaths). The response carries the result, the H-Graph's name,
        its new generation and the bridge candidates the new paths brought; `report_clearance`
        as in `requery`. With a `request_id` a repeat returns the first answer and adds
        nothing; with `expected_generation` the call adds only to that generation (ABORTED,
        reason GENERATION_MISMATCH, otherwise). With a `request_id` the call is repeated after a
        transient error (HgraphError.transient), as `retries` says; without one never (it
        could add the paths twice)."""
        request = service_pb2.AddPathsRequest(
            hgraph=hgraph, paths=make_paths(paths), measure=make_measure(measure, k, safety),
            report_clearance=report_clearance, request_id=request_id,
            expected_generation=expected_generation)

        def call():
            try:
                return self.stub.AddPaths(
                    request, timeout=timeout,
                    metadata=self._metadata(hgraph.split("/hgraphs/", 1)[0]))
            except grpc.RpcError as e:
                _raise(e)

        return self._retrying(call) if request_id else call()

    def check(self, paths, *, session: Optional[str] = None,
              resolution: Optional[float] = None, k: Optional[float] = None,
              sampled: bool = False, timeout: Optional[float] = None) -> CheckOutcome:
        """Checks each path in the session's scene as a merge checks its inputs (CheckPaths).

        The paths need not share endpoints; a path of one waypoint is checked where it stands.
        `sampled` asks for the collision test at the samples only (no clearance, no certificate).
        """
        def call():
            request = service_pb2.CheckPathsRequest(
                session=session or self.session or "", paths=make_paths(paths), sampled=sampled)
            if resolution is not None:
                request.resolution = resolution
            if k is not None:
                request.k = k
            try:
                return self.stub.CheckPaths(request, timeout=timeout,
                                            metadata=self._metadata(request.session))
            except grpc.RpcError as e:
                _raise(e)

        response = self._recovering(call, session)
        return CheckOutcome(list(response.paths), response.collision_checks,
                            response.distance_queries, response.resolution, response.elapsed_ms)

    def plan(self, *, count: int = 1, planner: str = "", time_per_path_s: float = 0,
             seed: int = 1, simplify: bool = False, session: Optional[str] = None,
             start: Optional[Sequence[float]] = None, goal: Optional[Sequence[float]] = None,
             timeout: Optional[float] = None) -> "PlanOutcome":
        """Plans input paths with the server's OMPL planners; returns the Path messages found
        (a list), with the attempts that found none in its `failures`."""
        def call():
            request = service_pb2.PlanPathsRequest(
                session=session or self.session or "", planner=planner, count=count,
                time_per_path_s=time_per_path_s, seed=seed, simplify=simplify,
                report_failures=True)
            if start is not None:
                request.start.values.extend(start)
            if goal is not None:
                request.goal.values.extend(goal)
            outcome = PlanOutcome()
            try:
                for event in self.stub.PlanPaths(request, timeout=timeout,
                                                 metadata=self._metadata(request.session)):
                    if event.HasField("failure"):
                        outcome.failures.append(PlanFailure(event.index, event.elapsed_ms,
                                                            event.failure))
                    else:
                        outcome.append(event.path)
            except grpc.RpcError as e:
                _raise(e)
            return outcome

        return self._recovering(call, session)


    def solve(self, budget_s: float = 3.0, *, portfolio=None,
              measure: Union[str, merge_pb2.Measure] = "length", k: Optional[float] = None,
              safety: Optional[float] = None, plan_fraction: Optional[float] = None,
              parallel: int = 0, seed: int = 1,
              options: Optional[merge_pb2.MergeOptions] = None,
              session: Optional[str] = None, start: Optional[Sequence[float]] = None,
              goal: Optional[Sequence[float]] = None,
              on_progress: Optional[Callable[[service_pb2.SolveProgress], None]] = None,
              timeout: Optional[float] = None) -> SolveOutcome:
        """The best certified path within `budget_s` seconds (Solve): a portfolio of the
        server's OMPL planners runs and each path is merged into one H-Graph as it arrives.

        `portfolio`: None for the server's default, else a mapping or a list of pairs of planner
        name and runs ({"bitstar": 2, "prm": 4}). `plan_fraction`: the share of the budget the
        planners may use (None: the server's 0.7). A budget in which no path is found is not an
        error: the outcome's `found` is False and result.message says why. `timeout` (the
        call's deadline) should leave room beyond the budget (the result comes within 10% of it).
        """
        entries = []
        if portfolio is not None:
            items = portfolio.items() if hasattr(portfolio, "items") else portfolio
            for name, runs in items:
                entries.append(service_pb2.PortfolioEntry(planner=name, runs=runs))

        def call():
            request = service_pb2.SolveRequest(
                session=session or self.session or "", budget_s=budget_s, portfolio=entries,
                measure=make_measure(measure, k, safety), parallel=parallel, seed=seed)
            if plan_fraction is not None:
                request.plan_fraction = plan_fraction
            if options is not None:
                request.options.CopyFrom(options)
            if start is not None:
                request.start.values.extend(start)
            if goal is not None:
                request.goal.values.extend(goal)
            events = []
            try:
                for event in self.stub.Solve(request, timeout=timeout,
                                             metadata=self._metadata(request.session)):
                    if event.HasField("result"):
                        return SolveOutcome(event.result, event.hgraph, events,
                                            event.generation, event.retention)
                    events.append(event.progress)
                    if on_progress is not None:
                        on_progress(event.progress)
            except grpc.RpcError as e:
                _raise(e)
            raise HgraphError(grpc.StatusCode.INTERNAL, "the stream ended without a result")

        return self._recovering(call, session)


def connect(target: str, *, wait_s: float = 10.0, **kwargs) -> Client:
    """A client whose channel is ready (waits up to wait_s for the server)."""
    client = Client(target, **kwargs)
    try:
        grpc.channel_ready_future(client.channel).result(timeout=wait_s)
    except grpc.FutureTimeoutError:
        client.close()
        raise HgraphError(grpc.StatusCode.UNAVAILABLE,
                          f"no hgraph server answered at {target} within {wait_s} s") from None
    return client
