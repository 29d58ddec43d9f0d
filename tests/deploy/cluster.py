"""Replicas of hgraph-server behind Debian's nginx on loopback, for the deploy tests
(affinity_test.py, store_failover_test.py, store_restart_test.py).

nginx runs deploy/base/nginx/hgraph.conf as Kubernetes and compose do, with two things
templated for loopback: its listen port, and the upstream list (the Kubernetes line of
deploy/base/nginx/upstreams.inc, its name:port replaced by each replica's loopback port).

Importing this module puts tests/integration on sys.path, for server_process and redis_process.
"""
import pathlib
import re
import shutil
import signal
import socket
import subprocess
import sys
import time

import grpc

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[1] / "integration"))
from server_process import ServerProcess, free_port  # noqa: E402

SKIP = 77  # CTest's SKIP_RETURN_CODE for the deploy tests

# grpc.health.v1.HealthCheckResponse{status: SERVING}.
HEALTH_SERVING = b"\x08\x01"


def nginx_binary():
    """Debian's nginx, or None when it is not installed."""
    found = shutil.which("nginx")
    if found:
        return found
    return "/usr/sbin/nginx" if pathlib.Path("/usr/sbin/nginx").exists() else None


def redis_binary():
    return shutil.which("redis-server")


def missing_tools(need_redis):
    """The SKIP line for a tool the test needs and this machine lacks, or None."""
    needed = [("nginx", nginx_binary)] + ([("redis-server", redis_binary)] if need_redis else [])
    for name, find in needed:
        if find() is None:
            return f"SKIP: {name} is not installed (scripts/install-deps.sh installs it)"
    return None


def print_failure_logs(replicas, nginx, lines=30):
    """Each replica's last `lines` log lines and nginx's error log (when it started)."""
    for r in replicas:
        print(r.report(lines))
    if nginx is not None:
        print("--- nginx error.log\n" + nginx.error_log())


class Replica(ServerProcess):
    """One hgraph-server on 127.0.0.1:<port> (a free port chosen now unless `port` is given),
    one worker thread, no metrics listener, a short shutdown (`--drain-s 0 --grace-s 2`), and
    `flags` (for example "--store", redis_url). `restart` starts it again on the same port; the
    log of every run so far is kept (`lines`)."""

    def __init__(self, binary, index, *flags, port=None):
        self.index = index
        self.binary = binary
        self.flags = flags
        self.earlier_log = []  # the log lines of the runs before the current one
        self.listen_port = port or free_port()
        self._start()

    def _start(self):
        super().__init__(self.binary, "--listen", f"127.0.0.1:{self.listen_port}",
                         "--metrics-listen", "", "--threads", "1", "--drain-s", "0",
                         "--grace-s", "2", *self.flags, name=f"replica {self.index}")

    def lines(self):
        """Every log line of every run so far."""
        return self.earlier_log + list(self.log)

    def sessions(self):
        """Session names in this replica's call log lines ("<Method> session=<name> ...")."""
        names = set()
        for line in self.lines():
            m = re.search(r" session=(sessions/[0-9a-f]{32})", line)
            if m:
                names.add(m.group(1))
        return names

    def calls(self, session):
        return [line for line in self.lines() if f" session={session}" in line]

    def built(self, hgraph_name):
        """Whether this replica merged the H-Graph (its MergePaths log line names the session)."""
        session = hgraph_name.split("/hgraphs/", 1)[0]
        return any(" MergePaths session=" + session in line for line in self.lines())

    def stop(self, timeout=30):
        return super().stop(timeout)

    def restart(self, timeout=30):
        """SIGTERM, the exit status (0 expected), then a new process on the same port, SERVING
        before this returns. Returns the old run's exit status."""
        status = self.stop(timeout)
        self.whole_log()
        self.earlier_log += list(self.log)
        self._start()
        wait_serving(self.target)
        return status

    def report(self, lines=30):
        return f"--- replica {self.index} log\n" + "".join(self.lines()[-lines:])


def wait_serving(target, within_s=20):
    """Waits until grpc.health.v1 on `target` answers SERVING; raises RuntimeError otherwise."""
    deadline = time.monotonic() + within_s
    last = "no answer"
    with grpc.insecure_channel(target) as channel:
        check = channel.unary_unary("/grpc.health.v1.Health/Check")
        while time.monotonic() < deadline:
            try:
                if check(b"", timeout=2) == HEALTH_SERVING:
                    return
                last = "not SERVING"
            except grpc.RpcError as e:
                last = e.code().name
            time.sleep(0.05)
    raise RuntimeError(f"{target} did not answer health SERVING within {within_s} s: {last}")


class Nginx:
    """nginx in front of `replicas`, its prefix, configuration and logs in `work`. `front` is
    the address clients call ("127.0.0.1:<port>")."""

    def __init__(self, deploy, work, replicas):
        binary = nginx_binary()
        if binary is None:
            raise RuntimeError("nginx is not installed")
        self.deploy = pathlib.Path(deploy)
        self.work = pathlib.Path(work)
        self.port = free_port()
        conf = self.work / "conf"
        (conf / "conf.d").mkdir(parents=True)
        for d in ("body", "proxy", "fastcgi", "uwsgi", "scgi"):
            (self.work / "tmp" / d).mkdir(parents=True)
        front = (self.deploy / "base" / "nginx" / "hgraph.conf").read_text()
        templated, n = re.subn(r"listen 50051 http2;", f"listen 127.0.0.1:{self.port} http2;",
                               front)
        assert n == 1, "deploy/base/nginx/hgraph.conf: no 'listen 50051 http2;' to template"
        (conf / "conf.d" / "hgraph.conf").write_text(templated)
        self.write_upstreams(replicas)
        w = self.work
        (conf / "nginx.conf").write_text(f"""
daemon off;
worker_processes 1;
pid {w}/nginx.pid;
error_log {w}/error.log info;
events {{ worker_connections 256; }}
http {{
    access_log {w}/access.log;
    client_body_temp_path {w}/tmp/body;
    proxy_temp_path {w}/tmp/proxy;
    fastcgi_temp_path {w}/tmp/fastcgi;
    uwsgi_temp_path {w}/tmp/uwsgi;
    scgi_temp_path {w}/tmp/scgi;
    include conf.d/hgraph.conf;
}}
""")
        self.proc = subprocess.Popen([binary, "-p", str(w), "-c", str(conf / "nginx.conf"),
                                      "-e", str(w / "error.log")],
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        self.front = f"127.0.0.1:{self.port}"
        for _ in range(100):
            if self.proc.poll() is not None:
                raise RuntimeError("nginx exited: " + self.proc.stdout.read() + self.error_log())
            try:
                socket.create_connection(("127.0.0.1", self.port), timeout=1).close()
                return
            except OSError:
                time.sleep(0.1)
        self.proc.kill()
        raise RuntimeError("nginx did not listen")

    def write_upstreams(self, replicas):
        k8s = [line for line in
               (self.deploy / "base" / "nginx" / "upstreams.inc").read_text().splitlines()
               if line.startswith("server ")]
        assert len(k8s) == 1, "deploy/base/nginx/upstreams.inc: expected one server line"
        (self.work / "conf" / "conf.d" / "upstreams.inc").write_text("".join(
            re.sub(r"server \S+", f"server 127.0.0.1:{r.port}", k8s[0]) + "\n" for r in replicas))

    def reload(self, replicas):
        """Points the upstreams at `replicas` and reloads (SIGHUP), as after a scale-out."""
        self.write_upstreams(replicas)
        self.proc.send_signal(signal.SIGHUP)
        time.sleep(1.0)  # the new workers take over

    def error_log(self, chars=3000):
        log = self.work / "error.log"
        return log.read_text()[-chars:] if log.exists() else ""

    def stop(self):
        self.proc.send_signal(signal.SIGQUIT)
        try:
            self.proc.wait(timeout=20)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
