#!/usr/bin/env python3
"""kustomize_render.py renders the lab overlay as kustomize does, where no kubectl can tell (deploy_check
compares the two where kubectl is installed): the namespace, the labels (on metadata only), the images,
the JSON patch, the generated Secrets; and it refuses what it does not support instead of ignoring it.

Usage: kustomize_render_test.py --source REPO. Exit 0: all passed; 1: a check failed.
"""
import argparse
import base64
import os
import shutil
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import kustomize_render  # noqa: E402

passed, failed = 0, 0


def check(ok, what):
    global passed, failed
    print(("ok    " if ok else "FAIL  ") + what)
    passed, failed = passed + bool(ok), failed + (not ok)


def refuses(folder, edit, expected, what):
    """Edits the overlay's kustomization (old -> new) in a copy, and expects a RenderError containing expected."""
    path = os.path.join(folder, "k8s", "overlays", "lab", "kustomization.yaml")
    original = open(path).read()
    old, new = edit
    if original.count(old) != 1:
        check(False, f"{what}: the overlay no longer has {old!r} once (update this case)")
        return
    with open(path, "w") as f:
        f.write(original.replace(old, new))
    try:
        kustomize_render.render(os.path.dirname(path))
        check(False, f"{what}: rendered without an error")
    except kustomize_render.RenderError as e:
        check(expected in str(e), f"{what}: {e}")
    finally:
        with open(path, "w") as f:
            f.write(original)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--source", required=True)
    a = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="kgd_kustomize_render_")
    try:
        deploy = os.path.join(tmp, "deploy")
        shutil.copytree(os.path.join(a.source, "deploy"), deploy, ignore=shutil.ignore_patterns("secrets"))
        secrets = os.path.join(deploy, "k8s", "overlays", "lab", "secrets")
        os.makedirs(secrets)
        files = {"tokens.txt": b"t0 admin admin\n", "tls.crt": b"CERT\n", "tls.key": b"KEY\n", "ca.pem": b"CA\n", "worker-token": b"t1\n"}
        for name, data in files.items():
            with open(os.path.join(secrets, name), "wb") as f:
                f.write(data)
        objects = kustomize_render.render(os.path.join(deploy, "k8s", "overlays", "lab"))
        by = {(o["kind"], o["metadata"]["name"]): o for o in objects}
        check(sorted(by) == sorted([("Namespace", "kgd"), ("StatefulSet", "kgd-server"), ("Service", "kgd-server"), ("Service", "kgd-web"),
                                    ("Deployment", "kgd-worker"), ("NetworkPolicy", "kgd-server"), ("NetworkPolicy", "kgd-worker"),
                                    ("ScaledObject", "kgd-worker"), ("Secret", "kgd-tokens"), ("Secret", "kgd-tls"), ("Secret", "kgd-worker-token")]),
              f"the overlay's 11 objects: {sorted(by)}")
        check("namespace" not in by[("Namespace", "kgd")]["metadata"], "the Namespace itself has no namespace")
        check(all(o["metadata"].get("namespace") == "kgd" for o in objects if o["kind"] != "Namespace"), "every other object is in namespace kgd")
        base = [o for o in objects if o["kind"] != "Secret"]
        check(all(o["metadata"]["labels"].get("app.kubernetes.io/part-of") == "kgd" for o in base), "the base's label is on each base object's metadata")
        sts, dep = by[("StatefulSet", "kgd-server")], by[("Deployment", "kgd-worker")]
        check("app.kubernetes.io/part-of" not in sts["spec"]["selector"]["matchLabels"] and
              "app.kubernetes.io/part-of" not in sts["spec"]["template"]["metadata"]["labels"], "but not on selectors or pod templates")
        check(sts["spec"]["template"]["spec"]["containers"][0]["image"] == "registry.example.org/kgd/kgd-server:0.1" and
              dep["spec"]["template"]["spec"]["containers"][0]["image"] == "registry.example.org/kgd/kgd-worker:0.1", "the images from the registry, tag 0.1")
        check(sts["spec"]["volumeClaimTemplates"][0]["spec"]["resources"]["requests"]["storage"] == "100Gi", "the patch makes the volume 100Gi")
        tls = by[("Secret", "kgd-tls")]
        decoded = {k: base64.b64decode(v) for k, v in tls["data"].items()}
        check(tls["type"] == "kubernetes.io/tls" and decoded == {"tls.crt": b"CERT\n", "tls.key": b"KEY\n", "ca.crt": b"CA\n"},
              "Secret kgd-tls: its type, and the files under their keys")
        check(by[("Secret", "kgd-tokens")]["type"] == "Opaque" and base64.b64decode(by[("Secret", "kgd-worker-token")]["data"]["token"]) == b"t1\n",
              "the other Secrets are Opaque, with the files' bytes")

        refuses(deploy, ("generatorOptions:\n", "commonLabels: {team: lab}\ngeneratorOptions:\n"), "commonLabels", "an unsupported field")
        refuses(deploy, ("  disableNameSuffixHash: true\n", "  disableNameSuffixHash: false\n"), "hashes are not supported", "name suffix hashes")
        refuses(deploy, ("{kind: StatefulSet, name: kgd-server}", "{kind: StatefulSet, name: kgd-serve}"), "no object matches", "a patch that matches nothing")
        refuses(deploy, ("/spec/volumeClaimTemplates/0/spec/resources/requests/storage", "/spec/volumeClaimTemplates/0/spec/size/storage"),
                "no such path", "a patch on a missing path")
        refuses(deploy, ("secrets/worker-token", "secrets/no-such-file"), "no-such-file", "a generator's missing file")
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print(f"{passed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
