#!/usr/bin/env bash
# The Python client as a package: installs client/python (copied to a temporary folder, so the
# source tree stays clean) with pip into a temporary target, offline, as a user would with
# Debian's python3-grpcio; imports it from there alone, and runs its example against a real
# hgraph-server on loopback. Usage: python_package_test.sh SOURCE_DIR SERVER_BINARY
set -euo pipefail
root=$1
server_bin=$(readlink -f "$2")
work=$(mktemp -d)
server=""
cleanup() {
  if [ -n "$server" ]; then kill -TERM "$server" 2> /dev/null || true; wait "$server" || true; fi
  rm -rf "$work"
}
trap cleanup EXIT
cp -r "$root/client/python" "$work/src"
HGRAPH_PROTO_DIR="$root/proto" /usr/bin/python3 -m pip install --quiet --no-deps \
  --no-build-isolation --no-index --target "$work/site" "$work/src"
cd "$work"
# Nothing from the source tree or the build: only the installed package.
export PYTHONPATH="$work/site" PYTHONDONTWRITEBYTECODE=1
/usr/bin/python3 - << 'PY'
import hgraph_client
from hgraph.v1 import service_pb2, service_pb2_grpc
assert hgraph_client.__file__.startswith(__import__("os").environ["PYTHONPATH"]), hgraph_client.__file__
assert "session_id" in service_pb2.CreateSessionRequest.DESCRIPTOR.fields_by_name
assert hasattr(service_pb2_grpc, "PathMergerStub")
print("imported", hgraph_client.__file__)
PY
"$server_bin" --listen 127.0.0.1:0 --metrics-listen "" --threads 2 --drain-s 0 \
  > "$work/server.out" 2> "$work/server.log" &
server=$!
for _ in $(seq 100); do
  grep -q "grpc_port=" "$work/server.out" 2> /dev/null && break
  sleep 0.1
done
port=$(sed -n 's/.*grpc_port=\([0-9]*\).*/\1/p' "$work/server.out")
[ -n "$port" ] || { echo "hgraph-server did not start"; cat "$work/server.log"; exit 1; }
/usr/bin/python3 "$work/src/examples/merge_circles.py" --server "127.0.0.1:$port" \
  --scene "$root/tests/data/circles/scene.json" --paths "$root/tests/data/circles/paths.txt"
echo "python package: installed, imported, example ran"
