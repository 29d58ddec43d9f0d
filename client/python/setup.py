"""Builds the hgraph.v1 stubs into the package at build time (pyproject.toml has the rest).

The stubs come from proto/hgraph/v1/*.proto (two folders up, or HGRAPH_PROTO_DIR) through the
system protoc and grpc_python_plugin (Debian: protobuf-compiler, protobuf-compiler-grpc), as
CMake builds them into <build>/python: Debian's python3-grpc-tools bundles a protoc too old
for proto3 `optional`."""
import os
import pathlib
import shutil
import subprocess

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = pathlib.Path(__file__).resolve().parent


class BuildPyWithStubs(build_py):
    def run(self):
        super().run()
        proto = pathlib.Path(os.environ.get("HGRAPH_PROTO_DIR", HERE.parent.parent / "proto"))
        sources = sorted((proto / "hgraph" / "v1").glob("*.proto"))
        if not sources:
            raise SystemExit(f"hgraph-client: no hgraph/v1/*.proto under {proto}; install from a "
                             "clone of hgraph, or set HGRAPH_PROTO_DIR to its proto/ folder")
        protoc, plugin = shutil.which("protoc"), shutil.which("grpc_python_plugin")
        if not protoc or not plugin:
            raise SystemExit("hgraph-client: needs protoc and grpc_python_plugin "
                             "(Debian: protobuf-compiler protobuf-compiler-grpc)")
        out = pathlib.Path(self.build_lib)
        subprocess.check_call([protoc, f"--proto_path={proto}", f"--python_out={out}",
                               f"--grpc_python_out={out}",
                               f"--plugin=protoc-gen-grpc_python={plugin}",
                               *map(str, sources)])
        for package in (out / "hgraph", out / "hgraph" / "v1"):
            (package / "__init__.py").touch()


setup(cmdclass={"build_py": BuildPyWithStubs})
