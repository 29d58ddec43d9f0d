"""redis-server as a child process on a loopback port, for the tests of the shared store
(store_test.py here, tests/deploy/store_failover_test.py and store_restart_test.py through
tests/deploy/cluster.py). Commands go over a raw socket (RESP), so the tests need no Redis
client library.
"""
import pathlib
import shutil
import signal
import socket
import subprocess
import time

from server_process import free_port

REDIS = shutil.which("redis-server") or "/usr/bin/redis-server"


class Redis:
    """redis-server on 127.0.0.1:<port>, its data in `folder` (append-only file on)."""

    def __init__(self, folder, port=None):
        self.folder = pathlib.Path(folder)
        self.port = port or free_port()
        self.proc = None
        self.start()

    def start(self):
        self.proc = subprocess.Popen(
            [REDIS, "--port", str(self.port), "--bind", "127.0.0.1", "--save", "",
             "--appendonly", "yes", "--appendfsync", "always", "--dir", str(self.folder),
             "--protected-mode", "no", "--daemonize", "no"],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        for _ in range(200):
            if self.proc.poll() is not None:
                raise RuntimeError("redis-server exited: " + self.proc.stdout.read())
            try:
                if self.command("PING") == "PONG":
                    return
            except (OSError, RuntimeError):  # not listening yet, or LOADING its append-only file
                time.sleep(0.02)
        raise RuntimeError("redis-server did not answer")

    def stop(self, sig=signal.SIGTERM):
        if self.proc.poll() is None:
            self.proc.send_signal(sig)
            self.proc.wait(timeout=20)

    @property
    def url(self):
        return f"redis://127.0.0.1:{self.port}"

    def command(self, *args):
        """One command over a raw socket (RESP); the reply's string, integer or None."""
        parts = [a if isinstance(a, bytes) else str(a).encode() for a in args]
        wire = b"*%d\r\n" % len(parts) + b"".join(b"$%d\r\n%s\r\n" % (len(p), p) for p in parts)
        with socket.create_connection(("127.0.0.1", self.port), timeout=5) as s:
            s.sendall(wire)
            f = s.makefile("rb")
            line = f.readline()
            kind, rest = line[:1], line[1:-2]
            if kind == b"+":
                return rest.decode()
            if kind == b":":
                return int(rest)
            if kind == b"-":
                raise RuntimeError(rest.decode())
            if kind == b"$":
                n = int(rest)
                return None if n < 0 else f.read(n + 2)[:-2]
            if kind == b"*":
                return [f.readline() for _ in range(2 * int(rest))][1::2]
            raise RuntimeError(f"unexpected reply {line!r}")

    def keys(self, pattern):
        return [k.strip().decode() for k in self.command("KEYS", pattern)]
