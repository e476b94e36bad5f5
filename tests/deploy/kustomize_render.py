"""A kustomize renderer for the features deploy/k8s uses, so that the manifests are checked where kubectl
is not installed (CI installs none: Debian 12's kubernetes-client is 1.20, whose kustomize knows neither
`labels` nor `patches`).

Supported, as `kubectl kustomize` (kustomize v5) renders them:
  resources        files (every YAML document) and folders with their own kustomization, in order
  namespace        metadata.namespace of every namespaced object
  labels           `pairs` added to metadata.labels (not to selectors or pod templates)
  images           newName / newTag / digest of any `containers` or `initContainers` image by name
  secretGenerator, configMapGenerator
                   `files` (KEY=PATH or PATH) and `literals` (KEY=VALUE), `type`; only with
                   generatorOptions.disableNameSuffixHash (no name hashes)
  patches          JSON 6902 patches (add, replace, remove) on targets by kind, name, namespace, group, version
Anything else in a kustomization is an error (RenderError): an unsupported field is never ignored. Stricter
than kustomize: a patch whose target matches no object is an error too (kustomize skips it).

render(folder) -> list of objects (dicts). Secret data is base64 without line breaks; kubectl wraps it at
70 columns, which the API server ignores, so compare with normalized() objects.
"""
import base64
import copy
import os

import yaml


class RenderError(Exception):
    pass


SUPPORTED = {"apiVersion", "kind", "resources", "namespace", "labels", "images", "generatorOptions",
             "secretGenerator", "configMapGenerator", "patches"}
# Kinds without a namespace (the ones a kustomization here could hold).
CLUSTER_SCOPED = {"Namespace", "ClusterRole", "ClusterRoleBinding", "CustomResourceDefinition", "PersistentVolume",
                  "StorageClass", "PriorityClass", "IngressClass", "ValidatingWebhookConfiguration",
                  "MutatingWebhookConfiguration", "APIService"}


def _kustomization(folder):
    for name in ("kustomization.yaml", "kustomization.yml", "Kustomization"):
        path = os.path.join(folder, name)
        if os.path.isfile(path):
            with open(path) as f:
                k = yaml.safe_load(f) or {}
            unsupported = set(k) - SUPPORTED
            if unsupported:
                raise RenderError(f"{path}: fields this renderer does not support: {', '.join(sorted(unsupported))}")
            return k, path
    raise RenderError(f"{folder}: no kustomization.yaml")


def _generated(k, path, folder):
    options = k.get("generatorOptions") or {}
    if set(options) - {"disableNameSuffixHash"}:
        raise RenderError(f"{path}: generatorOptions: only disableNameSuffixHash is supported")
    out = []
    for field, kind in (("secretGenerator", "Secret"), ("configMapGenerator", "ConfigMap")):
        for g in k.get(field) or []:
            if set(g) - {"name", "type", "files", "literals"}:
                raise RenderError(f"{path}: {field} {g.get('name')}: only name, type, files and literals are supported")
            if not options.get("disableNameSuffixHash"):
                raise RenderError(f"{path}: {field} {g.get('name')}: name suffix hashes are not supported")
            raw = {}
            for entry in g.get("files") or []:
                key, _, rel = entry.partition("=") if "=" in entry else (os.path.basename(entry), "", entry)
                try:
                    with open(os.path.join(folder, rel), "rb") as f:
                        raw[key] = f.read()
                except OSError as e:
                    raise RenderError(f"{path}: {field} {g['name']}: {e}") from e
            for entry in g.get("literals") or []:
                key, _, value = entry.partition("=")
                raw[key] = value.encode()
            obj = {"apiVersion": "v1", "kind": kind, "metadata": {"name": g["name"]}}
            if kind == "Secret":
                obj["type"] = g.get("type", "Opaque")
                obj["data"] = {key: base64.b64encode(v).decode() for key, v in raw.items()}
            else:
                obj["data"] = {key: v.decode() for key, v in raw.items()}
            out.append(obj)
    return out


def _matches(obj, target):
    if set(target) - {"kind", "name", "namespace", "group", "version"}:
        raise RenderError(f"patch target {target}: only kind, name, namespace, group and version are supported")
    group, _, version = obj.get("apiVersion", "").rpartition("/")
    meta = obj.get("metadata", {})
    return all(want == have for want, have in ((target.get("kind"), obj.get("kind")), (target.get("name"), meta.get("name")),
                                               (target.get("namespace"), meta.get("namespace")),
                                               (target.get("group"), group), (target.get("version"), version))
               if want is not None)


def _pointer(path):
    if not path.startswith("/"):
        raise RenderError(f"JSON patch path {path!r} does not start with /")
    return [p.replace("~1", "/").replace("~0", "~") for p in path.split("/")[1:]]


def _json_patch(obj, ops, where):
    for op in ops:
        parts = _pointer(op.get("path", ""))
        parent = obj
        for p in parts[:-1]:
            try:
                parent = parent[int(p)] if isinstance(parent, list) else parent[p]
            except (KeyError, IndexError, ValueError, TypeError) as e:
                raise RenderError(f"{where}: {op.get('op')} {op.get('path')}: no such path") from e
        last = parts[-1]
        kind = op.get("op")
        try:
            if isinstance(parent, list):
                i = len(parent) if last == "-" else int(last)
                if kind == "add":
                    parent.insert(i, copy.deepcopy(op["value"]))
                elif kind == "replace":
                    parent[i] = copy.deepcopy(op["value"])
                elif kind == "remove":
                    del parent[i]
                else:
                    raise RenderError(f"{where}: JSON patch op {kind!r} is not supported")
            else:
                if kind in ("replace", "remove") and last not in parent:
                    raise KeyError(last)
                if kind in ("add", "replace"):
                    parent[last] = copy.deepcopy(op["value"])
                elif kind == "remove":
                    del parent[last]
                else:
                    raise RenderError(f"{where}: JSON patch op {kind!r} is not supported")
        except (KeyError, IndexError, ValueError, TypeError) as e:
            raise RenderError(f"{where}: {kind} {op.get('path')}: no such path") from e


def _patch(objects, k, path, folder):
    for n, p in enumerate(k.get("patches") or []):
        where = f"{path}: patches[{n}]"
        if set(p) - {"target", "patch", "path"} or "target" not in p:
            raise RenderError(f"{where}: only a target with a patch or a path is supported")
        text = p.get("patch")
        if text is None:
            with open(os.path.join(folder, p["path"])) as f:
                text = f.read()
        ops = yaml.safe_load(text)
        if not isinstance(ops, list):
            raise RenderError(f"{where}: only JSON 6902 patches (a list of operations) are supported")
        targets = [o for o in objects if _matches(o, p["target"])]
        if not targets:
            raise RenderError(f"{where}: no object matches the target {p['target']}")
        for o in targets:
            _json_patch(o, ops, where)


def _split_image(image):
    name, digest = (image.split("@", 1) + [None])[:2]
    slash = name.rfind("/")
    colon = name.rfind(":")
    tag = None
    if colon > slash:
        name, tag = name[:colon], name[colon + 1:]
    return name, tag, digest


def _images(node, rules):
    if isinstance(node, dict):
        for key, value in node.items():
            if key in ("containers", "initContainers") and isinstance(value, list):
                for c in value:
                    if isinstance(c, dict) and isinstance(c.get("image"), str):
                        name, tag, digest = _split_image(c["image"])
                        rule = rules.get(name)
                        if rule:
                            name = rule.get("newName", name)
                            if "digest" in rule:
                                tag, digest = None, rule["digest"]
                            elif "newTag" in rule:
                                tag, digest = str(rule["newTag"]), None
                            c["image"] = name + (f":{tag}" if tag else "") + (f"@{digest}" if digest else "")
            _images(value, rules)
    elif isinstance(node, list):
        for value in node:
            _images(value, rules)


def render(folder):
    folder = os.path.abspath(folder)
    k, path = _kustomization(folder)
    objects = []
    for r in k.get("resources") or []:
        target = os.path.normpath(os.path.join(folder, r))
        if os.path.isdir(target):
            objects += render(target)
        elif os.path.isfile(target):
            with open(target) as f:
                objects += [o for o in yaml.safe_load_all(f) if o]
        else:
            raise RenderError(f"{path}: resource {r} is neither a file nor a folder")
    objects += _generated(k, path, folder)
    _patch(objects, k, path, folder)
    if "namespace" in k:
        for o in objects:
            if o.get("kind") not in CLUSTER_SCOPED:
                o.setdefault("metadata", {})["namespace"] = k["namespace"]
    for entry in k.get("labels") or []:
        if set(entry) - {"pairs", "includeSelectors", "includeTemplates"} or entry.get("includeSelectors") or entry.get("includeTemplates"):
            raise RenderError(f"{path}: labels: only pairs are supported (not includeSelectors, includeTemplates, fields)")
        for o in objects:
            o.setdefault("metadata", {}).setdefault("labels", {}).update(entry.get("pairs") or {})
    rules = {}
    for i in k.get("images") or []:
        if set(i) - {"name", "newName", "newTag", "digest"}:
            raise RenderError(f"{path}: images: only name, newName, newTag and digest are supported")
        rules[i["name"]] = i
    _images(objects, rules)
    return objects


def normalized(objects):
    """Objects keyed by (apiVersion, kind, namespace, name), Secret data without line breaks (as the API
    server decodes it), for comparing two renderings."""
    out = {}
    for o in objects:
        o = copy.deepcopy(o)
        if o.get("kind") == "Secret":
            o["data"] = {key: "".join(v.split()) for key, v in (o.get("data") or {}).items()}
        meta = o.get("metadata", {})
        out[(o.get("apiVersion"), o.get("kind"), meta.get("namespace"), meta.get("name"))] = o
    return out
