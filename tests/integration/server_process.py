"""hgraph-server as a child process on loopback, for every test that runs the real server:
test_service.py (and test_security.py, bad_input_catalogue.py through it), cli_test.py,
tests/load/load_test.py and tests/deploy (through cluster.py), which put this folder on sys.path.

The server prints one line "hgraph-server ready grpc_port=N metrics_port=M" on stdout once it
listens (metrics_port 0 without a metrics listener). Its log (stderr) is drained by a thread into
`log`, so that the pipe never fills and a failure can show what the server said.
"""
import re
import signal
import socket
import subprocess
import threading


class ServerDidNotStart(RuntimeError):
    """The server exited, or printed something else, before its ready line."""


class IgnoredSigterm(AssertionError):
    """The server had not exited when the time after SIGTERM was up; it has been killed."""


def free_port():
    """A loopback port free now (for a server that must listen on a port known beforehand)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class ServerProcess:
    """One hgraph-server process started with `binary` and `flags`; `name` is what a failure to
    start calls it; `env` its environment (default: this process's). Attributes: proc, port,
    metrics_port, health_port, target ("127.0.0.1:<port>"), log."""

    def __init__(self, binary, *flags, name="server", env=None):
        self.proc = subprocess.Popen([binary, *flags], stdout=subprocess.PIPE,
                                     stderr=subprocess.PIPE, text=True, env=env)
        line = self.proc.stdout.readline()
        match = re.search(r"grpc_port=(\d+) metrics_port=(\d+)", line)
        if not match:
            self.proc.kill()
            raise ServerDidNotStart(f"{name} did not start: {line!r} {self.proc.stderr.read()}")
        self.port, self.metrics_port = int(match.group(1)), int(match.group(2))
        health = re.search(r"health_port=(\d+)", line)
        self.health_port = int(health.group(1)) if health else 0  # --health-listen
        self.target = f"127.0.0.1:{self.port}"
        self.log = []
        self._reader = threading.Thread(target=lambda: self.log.extend(self.proc.stderr),
                                        daemon=True)
        self._reader.start()

    def whole_log(self, timeout=10):
        """The log to its end, once the server has exited (the reader ends at the log's end)."""
        self._reader.join(timeout=timeout)
        return "".join(self.log)

    def stop(self, timeout):
        """SIGTERM (unless the server has exited already), then its exit status. Kills it and
        raises IgnoredSigterm if it has not exited within `timeout` seconds."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
                raise IgnoredSigterm("server ignored SIGTERM") from None
        return self.proc.returncode
