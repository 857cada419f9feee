"""The renderer behind test_deploy_k8s: ``deploy/k8s`` rendered the way kustomize renders it (only the kustomization
fields the manifests use; any other field is refused), and the lookups the manifest checks share."""

import copy
import re
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parents[2]
K8S = ROOT / "deploy" / "k8s"
README = ROOT / "deploy" / "README.md"
# The Kubernetes version the manifests are written for (schemas from kubernetes-validate).
K8S_VERSION = "1.30.0"
# Manifests that kustomization.yaml does not list but that deploy/README.md tells how to add.
OPTIONAL = ["optional/worker-hpa.yaml"]

WORKLOAD_KINDS = {"Deployment", "StatefulSet", "DaemonSet", "ReplicaSet", "Job"}
CLUSTER_SCOPED = {"Namespace", "ClusterRole", "ClusterRoleBinding", "PersistentVolume", "StorageClass",
                  "PriorityClass", "CustomResourceDefinition"}
# The kustomization fields this renderer implements, and how far.
KUSTOMIZATION_FIELDS = {"apiVersion", "kind", "namespace", "labels", "resources", "images"}


class RenderError(Exception):
    pass


def load_yaml_docs(path):
    with open(path) as f:
        return [d for d in yaml.safe_load_all(f) if d is not None]


def split_image(image):
    """`name[:tag][@digest]` -> (name, tag, digest); a registry port is not a tag."""
    digest = None
    if "@" in image:
        image, digest = image.split("@", 1)
    name, tag = image, None
    last = image.rsplit("/", 1)[-1]
    if ":" in last:
        name, tag = image.rsplit(":", 1)
    return name, tag, digest


def pod_spec(doc):
    if doc.get("kind") in WORKLOAD_KINDS:
        return doc["spec"]["template"]["spec"]
    if doc.get("kind") == "CronJob":
        return doc["spec"]["jobTemplate"]["spec"]["template"]["spec"]
    if doc.get("kind") == "Pod":
        return doc["spec"]
    return None


def containers(spec):
    return list(spec.get("initContainers") or []) + list(spec.get("containers") or [])


def render(kdir=K8S, extra=()):
    """The documents `kustomize build kdir` makes, for the kustomization features used in deploy/k8s; `extra` are
    more resource files, as if listed in `resources`."""
    kfile = Path(kdir) / "kustomization.yaml"
    k = yaml.safe_load(kfile.read_text())
    unknown = set(k) - KUSTOMIZATION_FIELDS
    if unknown:
        raise RenderError(f"{kfile}: kustomization fields {sorted(unknown)} are not implemented by this test's "
                          f"renderer (it knows {sorted(KUSTOMIZATION_FIELDS)}): implement them in "
                          f"{Path(__file__).name} or do without")
    if k.get("apiVersion") != "kustomize.config.k8s.io/v1beta1" or k.get("kind") != "Kustomization":
        raise RenderError(f"{kfile}: not a kustomize.config.k8s.io/v1beta1 Kustomization")
    docs = []
    for res in list(k.get("resources") or []) + list(extra):
        path = Path(kdir) / res
        if "://" in res or not path.is_file():
            raise RenderError(f"{kfile}: resource {res!r} is not a file in {kdir} (directories, remote bases and "
                              f"components are not implemented by this test's renderer)")
        for d in load_yaml_docs(path):
            if not isinstance(d, dict) or "kind" not in d or "apiVersion" not in d:
                raise RenderError(f"{path}: a document without kind/apiVersion")
            d = copy.deepcopy(d)
            d.setdefault("metadata", {})["_source"] = res
            docs.append(d)
    ns = k.get("namespace")
    for d in docs:
        meta = d["metadata"]
        if ns and d["kind"] == "Namespace" and meta.get("name") != ns:
            raise RenderError(f"{meta['_source']}: Namespace {meta.get('name')!r} would be renamed to {ns!r} by "
                              f"kustomize; name it {ns!r}")
        if ns and d["kind"] not in CLUSTER_SCOPED:
            meta["namespace"] = ns
    for entry in k.get("labels") or []:
        extra_keys = set(entry) - {"pairs", "includeSelectors", "includeTemplates"}
        if extra_keys or entry.get("includeSelectors") or entry.get("includeTemplates"):
            raise RenderError(f"{kfile}: labels entries other than plain `pairs` (metadata labels only) are not "
                              f"implemented by this test's renderer: {entry}")
        for d in docs:
            d["metadata"].setdefault("labels", {}).update({str(a): str(b) for a, b in entry["pairs"].items()})
    for entry in k.get("images") or []:
        if set(entry) - {"name", "newName", "newTag", "digest"}:
            raise RenderError(f"{kfile}: images entry {entry} has fields this test's renderer does not implement")
        for d in docs:
            spec = pod_spec(d)
            for c in containers(spec) if spec else []:
                name, tag, digest = split_image(c["image"])
                if name != entry["name"]:
                    continue
                name = entry.get("newName", name)
                if "digest" in entry:
                    tag, digest = None, entry["digest"]
                elif "newTag" in entry:
                    tag, digest = entry["newTag"], None
                c["image"] = name + (f":{tag}" if tag else "") + (f"@{digest}" if digest else "")
    return docs


def strip(d):
    d = copy.deepcopy(d)
    d["metadata"].pop("_source", None)
    return d


def describe(d):
    return f"{d['kind']}/{d['metadata'].get('name')} ({d['metadata'].get('_source')})"


def by_kind(docs, kind):
    return {d["metadata"]["name"]: d for d in docs if d["kind"] == kind}


def workloads(docs):
    return [d for d in docs if pod_spec(d) is not None]


def pod_labels(d):
    if d["kind"] == "CronJob":
        return d["spec"]["jobTemplate"]["spec"]["template"]["metadata"].get("labels") or {}
    if d["kind"] == "Pod":
        return d["metadata"].get("labels") or {}
    return d["spec"]["template"]["metadata"].get("labels") or {}


def selects(selector, labels):
    """Whether a LabelSelector (matchLabels, matchExpressions) or a plain map selects `labels`."""
    if selector is None:
        return False
    if "matchLabels" in selector or "matchExpressions" in selector:
        ok = all(labels.get(k) == v for k, v in (selector.get("matchLabels") or {}).items())
        for e in selector.get("matchExpressions") or []:
            key, op, values = e["key"], e["operator"], e.get("values") or []
            if op == "In":
                ok &= labels.get(key) in values
            elif op == "NotIn":
                ok &= key not in labels or labels[key] not in values
            elif op == "Exists":
                ok &= key in labels
            elif op == "DoesNotExist":
                ok &= key not in labels
            else:
                raise AssertionError(f"unknown selector operator {op}")
        return ok
    return all(labels.get(k) == v for k, v in selector.items())


def readme_secrets():
    """{name: {keys}} of the Secrets deploy/README.md creates with `kubectl create secret generic NAME
    --from-literal=KEY=...` (they hold credentials, so they are not in the manifests)."""
    text = README.read_text().replace("\\\n", " ")
    out = {}
    for line in text.splitlines():
        m = re.search(r"kubectl\b.*\bcreate secret generic ([a-z0-9.-]+)", line)
        if m:
            keys = set(re.findall(r"--from-literal=([A-Za-z0-9._-]+)=", line))
            keys |= set(re.findall(r"--from-file=([A-Za-z0-9._-]+)=", line))
            out.setdefault(m.group(1), set()).update(keys)
    return out
