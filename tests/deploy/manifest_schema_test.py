#!/usr/bin/env python3
"""The schema validation (validate_manifests.js) catches mistakes in deploy/k8s's manifests: each case
edits one line of a copy of the base, renders it (kustomize_render.py) and expects exactly one problem,
named by the object's kind, namespace/name and field. The unedited base must have none.

Usage: manifest_schema_test.py --source REPO. Exit 0: all passed; 1: a case failed; 77: skipped, no node
or no `npm ci` in tests/deploy (scripts/setup.sh runs it).
"""
import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import kustomize_render  # noqa: E402

# (what, file, the line as it is, the line with the mistake, the one problem expected)
CASES = [
    ("an unknown field", "worker.yaml", "      terminationGracePeriodSeconds: 60", "      terminationGracePeriodSecond: 60",
     "Deployment kgd/kgd-worker: spec.template.spec.terminationGracePeriodSecond: is not a field of the schema"),
    ("a wrong type", "server.yaml", "{name: grpc, containerPort: 7447}", '{name: grpc, containerPort: "7447"}',
     "StatefulSet kgd/kgd-server: spec.template.spec.containers[0].ports[0].containerPort: must be integer"),
    ("a ScaledObject with no scaleTargetRef", "worker-scaler.yaml", "  scaleTargetRef: {name: kgd-worker}\n", "",
     "ScaledObject kgd/kgd-worker: spec.scaleTargetRef: is required"),
    ("an unknown field of KEDA's schema", "worker-scaler.yaml", "  maxReplicaCount: 8", "  maxReplicas: 8",
     "ScaledObject kgd/kgd-worker: spec.maxReplicas: is not a field of the schema"),
    ("a value outside an enum", "network-policy.yaml", "  policyTypes: [Ingress]\n", "  policyTypes: [Inbound]\n",
     "NetworkPolicy kgd/kgd-server: spec.policyTypes[0]: must be equal to one of the allowed values (Egress, Ingress)"),
]


def validate(node, base, tmp):
    path = os.path.join(tmp, "objects.json")
    with open(path, "w") as f:
        json.dump(kustomize_render.render(base), f)
    r = subprocess.run([node, os.path.join(HERE, "validate_manifests.js"), path], capture_output=True, text=True)
    return r.returncode, r.stdout.strip().splitlines()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--source", required=True)
    a = ap.parse_args()
    node = shutil.which("node")
    if not node or not os.path.isdir(os.path.join(HERE, "node_modules", "kubernetes-models")):
        print("SKIP  no node or no tests/deploy/node_modules (npm ci in tests/deploy; scripts/setup.sh runs it)")
        return 77
    passed, failed = 0, 0
    tmp = tempfile.mkdtemp(prefix="kgd_manifest_schema_")
    try:
        pristine = os.path.join(a.source, "deploy", "k8s", "base")
        code, lines = validate(node, pristine, tmp)
        ok = code == 0 and lines[-1:] == ["8 objects, 0 problems"]
        print(("ok    " if ok else "FAIL  ") + "the base as it is fits the schemas: " + " | ".join(lines))
        passed, failed = passed + ok, failed + (not ok)
        for what, name, line, mistake, expected in CASES:
            base = os.path.join(tmp, "base")
            shutil.rmtree(base, ignore_errors=True)
            shutil.copytree(pristine, base)
            text = open(os.path.join(base, name)).read()
            if text.count(line) != 1:
                print(f"FAIL  {what}: {name} no longer has the line {line.strip()!r} once (update this case)")
                failed += 1
                continue
            with open(os.path.join(base, name), "w") as f:
                f.write(text.replace(line, mistake))
            code, lines = validate(node, base, tmp)
            ok = code == 1 and lines[:-1] == [expected]
            print(("ok    " if ok else "FAIL  ") + f"{what} ({name}) fails: " + " | ".join(lines) + ("" if ok else f"; expected exit 1 and only: {expected}"))
            passed, failed = passed + ok, failed + (not ok)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"{passed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
