"""The error details the hgraph server attaches to every error (hgraph/v1/service.proto): a
google.rpc.Status in the `grpc-status-details-bin` trailer with ErrorInfo (reason, domain
"hgraph.v1"), BadRequest (field violations) and RetryInfo.

The messages are declared here, in a private descriptor pool, with the names and field numbers
of googleapis' google/rpc/status.proto and error_details.proto, so that the client needs no
googleapis package (Debian 12 has none for Python) and does not clash with one that is
installed."""
from __future__ import annotations

import dataclasses
from typing import Optional, Sequence

from google.protobuf import any_pb2, descriptor_pb2, descriptor_pool, duration_pb2

try:  # protobuf >= 4.22
    from google.protobuf.message_factory import GetMessageClass as _message_class
except ImportError:  # Debian 12's protobuf 4.21
    from google.protobuf import message_factory as _factory

    def _message_class(descriptor):
        return _factory.MessageFactory(descriptor.file.pool).GetPrototype(descriptor)

DETAILS_KEY = "grpc-status-details-bin"
DOMAIN = "hgraph.v1"

_F = descriptor_pb2.FieldDescriptorProto


def _field(name, number, kind, label=_F.LABEL_OPTIONAL, type_name=None):
    field = _F(name=name, number=number, type=kind, label=label)
    if type_name:
        field.type_name = type_name
    return field


def _build_pool():
    pool = descriptor_pool.DescriptorPool()
    for dependency in (any_pb2, duration_pb2):
        pool.AddSerializedFile(dependency.DESCRIPTOR.serialized_pb)
    rpc = descriptor_pb2.FileDescriptorProto(
        name="hgraph_client/google_rpc.proto", package="google.rpc", syntax="proto3",
        dependency=["google/protobuf/any.proto", "google/protobuf/duration.proto"])
    rpc.message_type.add(name="Status", field=[
        _field("code", 1, _F.TYPE_INT32), _field("message", 2, _F.TYPE_STRING),
        _field("details", 3, _F.TYPE_MESSAGE, _F.LABEL_REPEATED, ".google.protobuf.Any")])
    info = rpc.message_type.add(name="ErrorInfo", field=[
        _field("reason", 1, _F.TYPE_STRING), _field("domain", 2, _F.TYPE_STRING),
        _field("metadata", 3, _F.TYPE_MESSAGE, _F.LABEL_REPEATED,
               ".google.rpc.ErrorInfo.MetadataEntry")])
    entry = info.nested_type.add(name="MetadataEntry", field=[
        _field("key", 1, _F.TYPE_STRING), _field("value", 2, _F.TYPE_STRING)])
    entry.options.map_entry = True
    bad = rpc.message_type.add(name="BadRequest", field=[
        _field("field_violations", 1, _F.TYPE_MESSAGE, _F.LABEL_REPEATED,
               ".google.rpc.BadRequest.FieldViolation")])
    bad.nested_type.add(name="FieldViolation", field=[
        _field("field", 1, _F.TYPE_STRING), _field("description", 2, _F.TYPE_STRING)])
    rpc.message_type.add(name="RetryInfo", field=[
        _field("retry_delay", 1, _F.TYPE_MESSAGE, type_name=".google.protobuf.Duration")])
    pool.Add(rpc)
    return pool


_POOL = _build_pool()
Status = _message_class(_POOL.FindMessageTypeByName("google.rpc.Status"))
ErrorInfo = _message_class(_POOL.FindMessageTypeByName("google.rpc.ErrorInfo"))
BadRequest = _message_class(_POOL.FindMessageTypeByName("google.rpc.BadRequest"))
RetryInfo = _message_class(_POOL.FindMessageTypeByName("google.rpc.RetryInfo"))
_TYPES = {f"type.googleapis.com/google.rpc.{cls.DESCRIPTOR.name}": cls
          for cls in (ErrorInfo, BadRequest, RetryInfo)}


@dataclasses.dataclass
class ErrorDetails:
    """What a failed call's google.rpc.Status says beyond its code and message."""
    reason: Optional[str] = None          # ErrorInfo.reason ("SESSION_NOT_FOUND", ...)
    domain: Optional[str] = None          # ErrorInfo.domain ("hgraph.v1")
    metadata: Optional[dict] = None       # ErrorInfo.metadata ({"field": ...})
    field_violations: Sequence[tuple] = ()  # BadRequest: (field, description) pairs
    retry_delay_s: Optional[float] = None  # RetryInfo: worth retrying as is, after this long


def decode(trailing_metadata) -> Optional[ErrorDetails]:
    """The details in a call's trailing metadata (grpc.RpcError.trailing_metadata()), or None
    when it carries none (a server older than them, or an error from gRPC itself)."""
    raw = None
    for key, value in trailing_metadata or ():
        if key == DETAILS_KEY:
            raw = value
    if raw is None:
        return None
    status = Status.FromString(raw)
    out = ErrorDetails()
    for detail in status.details:
        cls = _TYPES.get(detail.type_url)
        if cls is None:
            continue
        message = cls.FromString(detail.value)
        if cls is ErrorInfo:
            out.reason, out.domain = message.reason, message.domain
            out.metadata = dict(message.metadata)
        elif cls is BadRequest:
            out.field_violations = tuple((v.field, v.description)
                                         for v in message.field_violations)
        else:
            out.retry_delay_s = message.retry_delay.seconds + message.retry_delay.nanos / 1e9
    return out
