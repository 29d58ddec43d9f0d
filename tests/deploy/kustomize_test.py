#!/usr/bin/env python3
"""Renders every overlay of deploy/ with `kubectl kustomize` and checks the objects: the kinds
present, labels and selectors, ports, native gRPC probes, the shutdown budget
(terminationGracePeriodSeconds > preStop + --drain-s + --grace-s), resources, the HPA and PDB
targets, the nginx configuration (grpc_pass, consistent hash on x-hgraph-session), and the shared
store (every replica's --store, the Redis StatefulSet's volume and append-only file).
Usage: kustomize_test.py DEPLOY_DIR. Exits 77 (skipped) when kubectl is not installed."""
import pathlib
import shutil
import subprocess
import sys

import yaml

SKIP = 77
failures = []


def expect(condition, what):
    if not condition:
        failures.append(what)


def flag_value(args, env, name):
    for arg in args:
        if arg.startswith(name + "="):
            value = arg.split("=", 1)[1]
            if value.startswith("$(") and value.endswith(")"):
                value = env[value[2:-1]]
            return float(value)
    raise KeyError(name)


def check_overlay(deploy, overlay):
    rendered = subprocess.run(["kubectl", "kustomize", str(overlay)], check=True,
                              capture_output=True, text=True).stdout
    objects = [o for o in yaml.safe_load_all(rendered) if o]
    by_kind = {}
    for o in objects:
        by_kind.setdefault(o["kind"], {})[o["metadata"]["name"]] = o
    name = overlay.name
    for kind in ("Deployment", "Service", "HorizontalPodAutoscaler", "PodDisruptionBudget",
                 "ConfigMap"):
        expect(kind in by_kind, f"{name}: no {kind}")
    namespace = {o["metadata"].get("namespace") for o in objects}
    expect(len(namespace) == 1 and None not in namespace, f"{name}: one namespace, got {namespace}")

    configmaps = {n.rsplit("-", 1)[0]: o for n, o in by_kind.get("ConfigMap", {}).items()}
    flags = configmaps["hgraph-server-flags"]["data"]
    server = by_kind["Deployment"]["hgraph-server"]
    spec = server["spec"]["template"]["spec"]
    labels = server["spec"]["template"]["metadata"]["labels"]
    selector = server["spec"]["selector"]["matchLabels"]
    expect(all(labels.get(k) == v for k, v in selector.items()),
           f"{name}: the pod labels do not match the Deployment's selector")
    container = spec["containers"][0]
    ports = {p["name"]: p["containerPort"] for p in container["ports"]}
    expect(ports == {"grpc": 50051, "metrics": 9464, "health": 50052},
           f"{name}: server ports {ports}")
    expect("--listen=0.0.0.0:50051" in container["args"], f"{name}: --listen not on port 50051")
    # The probes reach the plaintext health-only port, so that they work with TLS on 50051.
    expect("--health-listen=0.0.0.0:50052" in container["args"],
           f"{name}: --health-listen not on port 50052")
    for probe in ("readinessProbe", "livenessProbe"):
        grpc = container.get(probe, {}).get("grpc", {})
        expect(grpc.get("port") == 50052, f"{name}: {probe} is not a gRPC probe on 50052")
    for part in ("requests", "limits"):
        res = container.get("resources", {}).get(part, {})
        expect("cpu" in res and "memory" in res, f"{name}: no cpu/memory {part}")
    # Every $(VAR) in the arguments comes from the flags ConfigMap the container reads.
    expect(container["envFrom"][0]["configMapRef"]["name"] ==
           [n for n in by_kind["ConfigMap"] if n.startswith("hgraph-server-flags")][0],
           f"{name}: envFrom does not name the generated flags ConfigMap")
    pre_stop = container["lifecycle"]["preStop"]["exec"]["command"]
    pre_stop_s = float(pre_stop[-1]) if pre_stop[0] == "sleep" else 0
    budget = pre_stop_s + flag_value(container["args"], flags, "--drain-s") + \
        flag_value(container["args"], flags, "--grace-s")
    expect(spec["terminationGracePeriodSeconds"] > budget,
           f"{name}: terminationGracePeriodSeconds {spec['terminationGracePeriodSeconds']} "
           f"<= preStop + drain + grace = {budget}")
    expect(spec.get("securityContext", {}).get("runAsNonRoot") is True, f"{name}: runs as root")

    headless = by_kind["Service"]["hgraph-headless"]["spec"]
    expect(headless.get("clusterIP") == "None", f"{name}: hgraph-headless is not headless")
    expect(all(labels.get(k) == v for k, v in headless["selector"].items()),
           f"{name}: hgraph-headless selects no server pod")
    expect({p["port"] for p in headless["ports"]} == {50051, 9464}, f"{name}: headless ports")

    hpa = by_kind["HorizontalPodAutoscaler"]["hgraph-server"]["spec"]
    expect(hpa["scaleTargetRef"]["name"] == "hgraph-server", f"{name}: HPA target")
    expect(hpa["metrics"][0]["resource"]["name"] == "cpu", f"{name}: HPA not on CPU")
    expect(hpa["minReplicas"] <= hpa["maxReplicas"], f"{name}: HPA min > max")
    pdb = by_kind["PodDisruptionBudget"]["hgraph-server"]["spec"]
    expect(all(labels.get(k) == v for k, v in pdb["selector"]["matchLabels"].items()),
           f"{name}: PDB selects no server pod")

    nginx = by_kind["Deployment"]["hgraph-nginx"]["spec"]["template"]["spec"]
    front = by_kind["Service"]["hgraph"]["spec"]
    nginx_labels = by_kind["Deployment"]["hgraph-nginx"]["spec"]["template"]["metadata"]["labels"]
    expect(all(nginx_labels.get(k) == v for k, v in front["selector"].items()),
           f"{name}: Service hgraph selects no nginx pod")
    conf = configmaps["hgraph-nginx"]["data"]
    text = conf["hgraph.conf"]
    expect("grpc_pass grpc://hgraph_servers;" in text, f"{name}: nginx has no grpc_pass")
    expect("hash $http_x_hgraph_session consistent;" in text,
           f"{name}: nginx does not hash on x-hgraph-session")
    expect("include conf.d/upstreams.inc;" in text, f"{name}: nginx does not include upstreams")
    expect("hgraph-headless:50051" in conf["upstreams.inc"], f"{name}: upstreams miss the Service")
    mounts = nginx["containers"][0]["volumeMounts"]
    expect(any(m["mountPath"] == "/etc/nginx/conf.d" for m in mounts), f"{name}: conf not mounted")
    # The shared store: every replica gets --store; the URL names the overlay's own Redis (a
    # StatefulSet with a persistent volume and the append-only file) or one outside.
    expect("--store=$(HGRAPH_STORE)" in container["args"], f"{name}: no --store argument")
    store = flags.get("HGRAPH_STORE", "")
    expect(store.startswith("redis://") or store.startswith("rediss://"),
           f"{name}: HGRAPH_STORE {store!r} is not a Redis URL")
    redis = by_kind.get("StatefulSet", {}).get("hgraph-redis")
    if redis is None:
        expect("hgraph-redis" not in store, f"{name}: HGRAPH_STORE names a Redis not deployed")
    else:
        expect("redis://hgraph-redis:6379" in store, f"{name}: HGRAPH_STORE {store!r} misses "
               "the overlay's Redis")
        rspec = redis["spec"]
        args = rspec["template"]["spec"]["containers"][0]["args"]
        expect(args[args.index("--appendonly") + 1] == "yes", f"{name}: Redis without AOF")
        claims = rspec.get("volumeClaimTemplates", [])
        mounts = rspec["template"]["spec"]["containers"][0]["volumeMounts"]
        expect(claims and any(m["name"] == claims[0]["metadata"]["name"] and
                              m["mountPath"] == args[args.index("--dir") + 1] for m in mounts),
               f"{name}: Redis's --dir is not on its persistent volume")
        rservice = by_kind["Service"].get("hgraph-redis", {}).get("spec", {})
        rlabels = rspec["template"]["metadata"]["labels"]
        expect(rservice and all(rlabels.get(k) == v for k, v in rservice["selector"].items()),
               f"{name}: Service hgraph-redis selects no Redis pod")
    # The file in deploy/ is what the affinity test runs nginx with.
    expect(text == (deploy / "base" / "nginx" / "hgraph.conf").read_text(),
           f"{name}: rendered hgraph.conf differs from deploy/base/nginx/hgraph.conf")
    return by_kind


def main():
    deploy = pathlib.Path(sys.argv[1])
    if shutil.which("kubectl") is None:
        print("SKIP: kubectl is not installed (scripts/install-deps.sh installs kubernetes-client)")
        return SKIP
    overlays = sorted(p for p in (deploy / "overlays").iterdir() if p.is_dir())
    expect(len(overlays) >= 3, "expected the dev, prod and external-redis overlays")
    rendered = {o.name: check_overlay(deploy, o) for o in overlays}
    if "prod" in rendered:
        prod = rendered["prod"]
        expect(prod["Deployment"]["hgraph-server"]["spec"]["replicas"] >= 3, "prod: < 3 replicas")
        expect(prod["PodDisruptionBudget"]["hgraph-server"]["spec"].get("maxUnavailable") == 1,
               "prod: PDB should allow one replica down")
        expect("hgraph-redis" in prod.get("StatefulSet", {}), "prod: no Redis StatefulSet")
    if "external-redis" in rendered:
        expect("StatefulSet" not in rendered["external-redis"],
               "external-redis: deploys a Redis of its own")
    for f in failures:
        print("FAIL:", f)
    print(f"{len(overlays)} overlays rendered, {len(failures)} problems")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
