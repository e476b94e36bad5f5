#!/usr/bin/env python3
"""deploy/ checked without a container engine or a cluster (neither runs on these machines):

1. the compose file parses and its services, volumes and secrets fit together;
2. the Kubernetes overlay renders (kubectl kustomize, when kubectl is installed) after
   deploy/make-secrets.sh, and every object has the fields its kind requires, with cross references
   that hold (selectors and labels, Service ports and container ports, volumes and mounts, Secrets,
   the KEDA target, probe commands that the image contains);
3. the images' entry commands run as plain processes: the server image's CMD (paths mapped into a
   temporary folder), its HEALTHCHECK, the worker's command from the Deployment, and a job submitted
   over TLS with a user token that the worker runs to the end.

Usage: deploy_check.py --source REPO --build BUILD. Exit 0: all passed; 1: a check failed (printed).
"""
import argparse
import os
import re
import shutil
import socket
import subprocess
import sys
import tempfile
import time

import yaml

failures = []


def check(ok, what):
    print(("ok    " if ok else "FAIL  ") + what)
    if not ok:
        failures.append(what)
    return ok


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# Fields each kind must have (dotted paths); a minimal schema of what kgd's manifests use.
REQUIRED = {
    ("v1", "Namespace"): ["metadata.name"],
    ("v1", "Service"): ["metadata.name", "spec.selector", "spec.ports"],
    ("v1", "Secret"): ["metadata.name", "data"],
    ("apps/v1", "StatefulSet"): ["metadata.name", "spec.serviceName", "spec.selector.matchLabels", "spec.template.metadata.labels",
                                 "spec.template.spec.containers", "spec.volumeClaimTemplates"],
    ("apps/v1", "Deployment"): ["metadata.name", "spec.selector.matchLabels", "spec.template.metadata.labels", "spec.template.spec.containers"],
    ("networking.k8s.io/v1", "NetworkPolicy"): ["metadata.name", "spec.podSelector", "spec.policyTypes"],
    ("keda.sh/v1alpha1", "ScaledObject"): ["metadata.name", "spec.scaleTargetRef.name", "spec.triggers"],
}


def get(obj, path):
    for part in path.split("."):
        if not isinstance(obj, dict) or part not in obj:
            return None
        obj = obj[part]
    return obj


def check_containers(name, pod, secrets, images):
    volumes = {v["name"]: v for v in pod.get("volumes", [])}
    for c in pod["containers"]:
        check(bool(c.get("image")) and bool(c.get("resources", {}).get("requests")), f"{name}/{c['name']}: image and resource requests")
        check(get(c, "securityContext.allowPrivilegeEscalation") is False, f"{name}/{c['name']}: no privilege escalation")
        for m in c.get("volumeMounts", []):
            check(m["name"] in volumes or m["name"] in images.get("claims", set()), f"{name}/{c['name']}: mount {m['name']} has a volume")
        for probe in ("readinessProbe", "livenessProbe"):
            cmd = get(c, f"{probe}.exec.command")
            if cmd:
                check(cmd[0] in images.get(c["image"].split(":")[0].split("/")[-1], set()),
                      f"{name}/{c['name']}: {probe} runs {cmd[0]}, which the image holds")
    for v in volumes.values():
        if "secret" in v:
            check(v["secret"]["secretName"] in secrets, f"{name}: volume {v['name']} names Secret {v['secret']['secretName']}, which exists")
    check(get(pod, "securityContext.runAsNonRoot") is True, f"{name}: runs as non-root")


def check_manifests(objects, images):
    by_kind = {}
    for o in objects:
        key = (o.get("apiVersion"), o.get("kind"))
        check(key in REQUIRED, f"{key[1]} {get(o, 'metadata.name')}: a known apiVersion/kind {key}")
        for path in REQUIRED.get(key, []):
            check(get(o, path) is not None, f"{key[1]} {get(o, 'metadata.name')}: has {path}")
        by_kind.setdefault(o["kind"], {})[get(o, "metadata.name")] = o
    secrets = set(by_kind.get("Secret", {}))
    workloads = {**by_kind.get("StatefulSet", {}), **by_kind.get("Deployment", {})}
    for name, w in workloads.items():
        labels = get(w, "spec.template.metadata.labels")
        sel = get(w, "spec.selector.matchLabels")
        check(all(labels.get(k) == v for k, v in sel.items()), f"{name}: selector matches its pod labels")
        claims = {get(c, "metadata.name") for c in (get(w, "spec.volumeClaimTemplates") or [])}
        check_containers(name, get(w, "spec.template.spec"), secrets, {**images, "claims": claims})
    for name, s in by_kind.get("Service", {}).items():
        targets = [w for w in workloads.values() if all(get(w, "spec.template.metadata.labels").get(k) == v for k, v in s["spec"]["selector"].items())]
        check(len(targets) == 1, f"Service {name}: selects one workload")
        if targets:
            ports = {p.get("name") for c in get(targets[0], "spec.template.spec.containers") for p in c.get("ports", [])}
            for p in s["spec"]["ports"]:
                check(p["targetPort"] in ports, f"Service {name}: targetPort {p['targetPort']} is a container port")
    for name, st in by_kind.get("StatefulSet", {}).items():
        check(st["spec"]["serviceName"] in by_kind.get("Service", {}), f"StatefulSet {name}: its serviceName is a Service")
    for name, so in by_kind.get("ScaledObject", {}).items():
        check(so["spec"]["scaleTargetRef"]["name"] in by_kind.get("Deployment", {}), f"ScaledObject {name}: scales a Deployment")
        check(any("kgd_queue_depth" in t["metadata"].get("query", "") for t in so["spec"]["triggers"]), f"ScaledObject {name}: on the queue depth")
    check(len(by_kind.get("NetworkPolicy", {})) >= 1, "a NetworkPolicy limits who reaches the server")
    check(len(secrets) == 3, "Secrets for tokens, TLS and the worker's token")
    return by_kind


def dockerfile_stages(path):
    """Per stage: the binaries it copies into /usr/local/bin, its CMD, its HEALTHCHECK command."""
    stages, current = {}, None
    text = open(path).read().replace("\\\n", " ")
    outs = {}
    for line in text.splitlines():
        m = re.match(r"FROM \S+ AS (\w+)", line)
        if m:
            current = stages.setdefault(m.group(1), {"bins": set(), "cmd": None, "health": None})
            continue
        m = re.match(r"COPY --from=build /out/([\w-]+)/ /", line)
        if m and current is not None:
            current["bins"].add(m.group(1))
        m = re.match(r"CMD (\[.*\])", line)
        if m and current is not None:
            current["cmd"] = yaml.safe_load(m.group(1))
        m = re.match(r"HEALTHCHECK .*CMD (\[.*\])", line)
        if m and current is not None:
            current["health"] = yaml.safe_load(m.group(1))
    return stages


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--source", required=True)
    ap.add_argument("--build", required=True)
    a = ap.parse_args()
    deploy = os.path.join(a.source, "deploy")
    tmp = tempfile.mkdtemp(prefix="kgd_deploy_check_")
    procs = []
    try:
        # -- the secrets script ------------------------------------------------------------------
        secrets = os.path.join(tmp, "secrets")
        r = subprocess.run(["bash", os.path.join(deploy, "make-secrets.sh"), secrets, "kgd-server", "server"], capture_output=True, text=True)
        if not check(r.returncode == 0, "make-secrets.sh makes certificates and tokens"):
            print(r.stderr)
            return 1
        tokens = {l.split()[2]: l.split()[0] for l in open(os.path.join(secrets, "tokens.txt")) if l.strip() and not l.startswith("#")}
        check(set(tokens) == {"admin", "worker", "user"}, "tokens.txt has an admin, a worker and a user token")
        check(oct(os.stat(secrets).st_mode & 0o777) == "0o700", "the secrets folder is 0700")

        # -- compose -----------------------------------------------------------------------------
        compose = yaml.safe_load(open(os.path.join(deploy, "compose.yaml")))
        services = compose.get("services", {})
        check(set(services) == {"server", "worker"}, "compose: a server and workers")
        check(get(services.get("worker", {}), "deploy.replicas") == 2, "compose: two workers")
        check(any(v.startswith("kgd-data:/data") for v in services.get("server", {}).get("volumes", [])) and "kgd-data" in compose.get("volumes", {}),
              "compose: the server's data on a named volume")
        check(any("7448" in p for p in services.get("server", {}).get("ports", [])), "compose: the web port published")
        for svc in services.values():
            for s in svc.get("secrets", []):
                check(s["source"] in compose.get("secrets", {}), f"compose: secret {s['source']} is declared")
        for name, s in compose.get("secrets", {}).items():
            check(os.path.basename(s["file"]) in os.listdir(secrets), f"compose: secret file {s['file']} is what make-secrets.sh makes")

        # -- the Dockerfile ------------------------------------------------------------------------
        stages = dockerfile_stages(os.path.join(deploy, "docker", "Dockerfile"))
        check({"build", "server", "worker", "cli"} <= set(stages), "Dockerfile: build, server, worker and cli stages")
        check("USER 10001" in open(os.path.join(deploy, "docker", "Dockerfile")).read(), "Dockerfile: the run images' user is not root")
        images = {"kgd-server": stages["server"]["bins"], "kgd-worker": stages["worker"]["bins"]}

        # -- Kubernetes ------------------------------------------------------------------------------
        kubectl = shutil.which("kubectl")
        if kubectl:
            overlay = os.path.join(tmp, "deploy")
            shutil.copytree(deploy, overlay)
            shutil.copytree(secrets, os.path.join(overlay, "k8s", "overlays", "lab", "secrets"))
            r = subprocess.run([kubectl, "kustomize", os.path.join(overlay, "k8s", "overlays", "lab")], capture_output=True, text=True)
            if check(r.returncode == 0, "kubectl kustomize renders overlays/lab"):
                objects = [o for o in yaml.safe_load_all(r.stdout) if o]
                check_manifests(objects, images)
        else:
            print("skip  the Kubernetes overlay: kubectl is not installed (its kustomize renders it)")
        base = [o for f in sorted(os.listdir(os.path.join(deploy, "k8s", "base"))) if f.endswith(".yaml") and f != "kustomization.yaml"
                for o in yaml.safe_load_all(open(os.path.join(deploy, "k8s", "base", f))) if o]
        check(all((o["apiVersion"], o["kind"]) in REQUIRED for o in base), "the base's files parse, each object of a known kind")
        worker_deploy = next(o for o in base if o["kind"] == "Deployment")

        # -- the entry commands as processes ----------------------------------------------------------
        grpc_port, http_port, internal_port = free_port(), free_port(), free_port()
        run_secrets = os.path.join(tmp, "run-secrets")
        os.makedirs(os.path.join(run_secrets, "kgd-tokens"))
        os.makedirs(os.path.join(run_secrets, "kgd-tls"))
        shutil.copy(os.path.join(secrets, "tokens.txt"), os.path.join(run_secrets, "kgd-tokens", "tokens.txt"))
        for src, dst in (("tls.crt", "tls.crt"), ("tls.key", "tls.key"), ("ca.pem", "ca.crt")):
            shutil.copy(os.path.join(secrets, src), os.path.join(run_secrets, "kgd-tls", dst))
        os.makedirs(os.path.join(run_secrets, "kgd-worker-token"))
        shutil.copy(os.path.join(secrets, "worker-token"), os.path.join(run_secrets, "kgd-worker-token", "token"))
        bins = {"kgd-server": os.path.join(a.build, "server", "kgd-server"), "kgd-worker": os.path.join(a.build, "worker", "kgd-worker"),
                "kgd": os.path.join(a.build, "client", "kgd")}

        def mapped(args):
            out = []
            for x in args:
                x = x.replace("/run/secrets", run_secrets).replace("/usr/local/share/kgd/web", os.path.join(a.source, "client", "web"))
                x = x.replace("0.0.0.0:7447", f"127.0.0.1:{grpc_port}").replace("0.0.0.0:7448", f"127.0.0.1:{http_port}")
                x = x.replace("127.0.0.1:7449", f"127.0.0.1:{internal_port}").replace("kgd-server:7447", f"localhost:{grpc_port}")
                out.append(os.path.join(tmp, "data") if x == "/data" else x)
            return out

        server_cmd = [bins["kgd-server"]] + mapped(stages["server"]["cmd"])
        log = open(os.path.join(tmp, "server.log"), "w")
        procs.append(subprocess.Popen(server_cmd, stdout=log, stderr=subprocess.STDOUT))
        deadline = time.time() + 30
        while time.time() < deadline and "http on" not in open(os.path.join(tmp, "server.log")).read():
            time.sleep(0.1)
        if not check("http on" in open(os.path.join(tmp, "server.log")).read(), "the server image's CMD starts kgd-server (TLS, tokens, web)"):
            print(open(os.path.join(tmp, "server.log")).read())
            return 1
        health = stages["server"]["health"]
        r = subprocess.run([bins[health[0]]] + mapped(health[1:]), capture_output=True, text=True)
        check(r.returncode == 0, "the server image's HEALTHCHECK (grpc.health.v1 on the loopback port) passes: " + r.stderr.strip())
        container = worker_deploy["spec"]["template"]["spec"]["containers"][0]
        shell = mapped([container["args"][0]])[0].replace("exec kgd-worker", "exec " + bins["kgd-worker"])
        env = dict(os.environ, POD_NAME="kgd-worker-test", OMP_NUM_THREADS="2")
        procs.append(subprocess.Popen(["/bin/sh", "-c", shell], env=env, stdout=open(os.path.join(tmp, "worker.log"), "w"), stderr=subprocess.STDOUT))
        r = subprocess.run([bins["kgd"], "submit", "sleeve_on_limb", "--iterations", "2", "--watch", "--json", "--server", f"localhost:{grpc_port}",
                            "--tls-ca", os.path.join(secrets, "ca.pem"), "--token", tokens["user"]], capture_output=True, text=True, timeout=300)
        check(r.returncode == 0 and "SUCCEEDED" in r.stdout, "the worker's command from the Deployment runs a job submitted over TLS with a user token")
        if r.returncode != 0:
            print(r.stdout, r.stderr, open(os.path.join(tmp, "worker.log")).read())
    finally:
        for p in procs:
            p.kill()
            p.wait()
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"{len(failures)} failed" if failures else "all passed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
