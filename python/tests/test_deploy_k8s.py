"""The Kubernetes manifests in ``deploy/k8s``, checked offline: rendered the way kustomize renders them (only the
kustomization fields they use; any other field fails the test), every document validated against the pinned
Kubernetes version's OpenAPI schemas (``kubernetes-validate``, strict: an unknown field is an error), and the
references between them checked (Service selectors and ports, Secrets, ConfigMaps, volumes, the ServiceAccount,
images, the worker's lack of database access). With ``VB_BIN`` set, every ``vb`` subcommand and flag the containers
use is checked against ``vb SUBCOMMAND --help``; with ``kubectl`` on the PATH, the rendering is compared with
``kubectl kustomize``'s. Nothing here talks to a cluster or the network."""

import copy
import os
import re
import shutil
import subprocess

import pytest
import yaml

from k8s_render import (CLUSTER_SCOPED, K8S, K8S_VERSION, OPTIONAL, README, RenderError, by_kind, containers, describe,
                        pod_labels, pod_spec, readme_secrets, render, selects, split_image, strip, workloads)


@pytest.fixture(scope="module")
def docs():
    return render()


@pytest.fixture(scope="module")
def all_docs():
    """The rendering with the optional manifests added."""
    return render(extra=OPTIONAL)


def test_the_kustomization_renders(docs):
    kinds = sorted((d["kind"], d["metadata"]["name"]) for d in docs)
    assert len(set(kinds)) == len(kinds), f"duplicate resources: {kinds}"
    names = {(d["kind"], d["metadata"]["name"]) for d in docs}
    for want in [("Namespace", "vertibench"), ("StatefulSet", "vb-postgres"), ("Deployment", "vb-coordinator"),
                 ("Service", "vb-coordinator"), ("Deployment", "vb-leaderboard"), ("Service", "vb-leaderboard"),
                 ("Deployment", "vb-worker")]:
        assert want in names, f"{want} missing from the rendering"
    for d in docs:
        if d["kind"] not in CLUSTER_SCOPED:
            assert d["metadata"]["namespace"] == "vertibench", describe(d)


def test_the_renderer_refuses_what_it_does_not_implement(tmp_path):
    (tmp_path / "a.yaml").write_text("apiVersion: v1\nkind: ConfigMap\nmetadata: {name: a}\n")
    (tmp_path / "kustomization.yaml").write_text(
        "apiVersion: kustomize.config.k8s.io/v1beta1\nkind: Kustomization\nresources: [a.yaml]\n"
        "commonLabels: {a: b}\n")
    with pytest.raises(RenderError, match="commonLabels"):
        render(tmp_path)


@pytest.mark.parametrize("source", ["kustomization"] + OPTIONAL)
def test_every_document_matches_the_kubernetes_schema(source, docs, all_docs):
    kv = pytest.importorskip("kubernetes_validate", reason="SKIPPED: kubernetes-validate is not installed "
                             "(python/pyproject.toml's test extras have it)")
    versions = kv.utils.all_versions()
    assert any(v.startswith(K8S_VERSION.rsplit(".", 1)[0] + ".") for v in versions), (
        f"kubernetes-validate {kv.version.__version__} has no schemas for Kubernetes {K8S_VERSION} (has {versions})")
    chosen = docs if source == "kustomization" else [d for d in all_docs if d["metadata"]["_source"] == source]
    assert chosen
    errors = []
    for d in chosen:
        try:
            kv.validate(strip(d), K8S_VERSION, strict=True)
        except kv.utils.ValidationError as e:
            errors.append(f"{describe(d)}: {'.'.join(str(p) for p in e.path)}: {e.message}")
        except kv.utils.SchemaNotFoundError as e:
            errors.append(f"{describe(d)}: {e.message}")
    assert not errors, "\n".join(errors)


def test_the_schema_check_rejects_unknown_fields_and_wrong_types():
    kv = pytest.importorskip("kubernetes_validate", reason="SKIPPED: kubernetes-validate is not installed")
    good = yaml.safe_load("""
        apiVersion: apps/v1
        kind: Deployment
        metadata: {name: x}
        spec:
          selector: {matchLabels: {a: b}}
          template:
            metadata: {labels: {a: b}}
            spec: {containers: [{name: x, image: "x:1"}]}
    """)
    kv.validate(good, K8S_VERSION, strict=True)
    typo = copy.deepcopy(good)
    typo["spec"]["template"]["spec"]["containers"][0]["imagePulPolicy"] = "Always"
    with pytest.raises(kv.utils.ValidationError):
        kv.validate(typo, K8S_VERSION, strict=True)
    wrong = copy.deepcopy(good)
    wrong["spec"]["replicas"] = "two"
    with pytest.raises(kv.utils.ValidationError):
        kv.validate(wrong, K8S_VERSION, strict=True)


def test_selectors_match_the_pods_and_ports_exist(all_docs):
    wls = workloads(all_docs)
    for w in wls:
        if w["kind"] in {"Deployment", "StatefulSet", "DaemonSet", "ReplicaSet"}:
            assert selects(w["spec"]["selector"], pod_labels(w)), (
                f"{describe(w)}: spec.selector does not select its own pod template's labels")
    for s in by_kind(all_docs, "Service").values():
        sel = s["spec"].get("selector")
        assert sel, f"{describe(s)}: no selector"
        matched = [w for w in wls if w["metadata"].get("namespace") == s["metadata"].get("namespace")
                   and selects(sel, pod_labels(w))]
        assert matched, f"{describe(s)}: selector {sel} matches no workload's pods"
        for w in matched:
            cports = [p for c in pod_spec(w)["containers"] for p in c.get("ports") or []]
            for p in s["spec"]["ports"]:
                target = p.get("targetPort", p["port"])
                ok = any(cp.get("name") == target for cp in cports) if isinstance(target, str) else any(
                    cp["containerPort"] == target for cp in cports)
                assert ok, f"{describe(s)}: targetPort {target!r} is no container port of {describe(w)}"
    for ss in by_kind(all_docs, "StatefulSet").values():
        gov = by_kind(all_docs, "Service").get(ss["spec"]["serviceName"])
        assert gov is not None, f"{describe(ss)}: serviceName {ss['spec']['serviceName']} is no Service"
        assert selects(gov["spec"]["selector"], pod_labels(ss)), f"{describe(gov)} does not select {describe(ss)}"
    for np in by_kind(all_docs, "NetworkPolicy").values():
        targets = [w for w in wls if selects(np["spec"]["podSelector"], pod_labels(w))]
        assert targets, f"{describe(np)}: podSelector matches no pods"
        for rule in np["spec"].get("ingress") or []:
            for peer in rule.get("from") or []:
                if "podSelector" in peer:
                    assert any(selects(peer["podSelector"], pod_labels(w)) for w in wls), (
                        f"{describe(np)}: ingress peer {peer} matches no pods")
            for p in rule.get("ports") or []:
                if isinstance(p.get("port"), str):
                    for t in targets:
                        assert any(cp.get("name") == p["port"] for c in pod_spec(t)["containers"]
                                   for cp in c.get("ports") or []), f"{describe(np)}: port {p['port']} not on {describe(t)}"
    for hpa in by_kind(all_docs, "HorizontalPodAutoscaler").values():
        ref = hpa["spec"]["scaleTargetRef"]
        assert ref["name"] in by_kind(all_docs, ref["kind"]), f"{describe(hpa)}: no {ref['kind']}/{ref['name']}"
        target = by_kind(all_docs, ref["kind"])[ref["name"]]
        for c in pod_spec(target)["containers"]:
            assert (c.get("resources") or {}).get("requests", {}).get("cpu"), (
                f"{describe(hpa)}: CPU utilisation needs CPU requests on {describe(target)}")


def test_every_referenced_object_exists(all_docs):
    secrets = {n: set((d.get("data") or {}) | (d.get("stringData") or {})) for n, d in
               by_kind(all_docs, "Secret").items()}
    made_by_hand = readme_secrets()
    assert set(made_by_hand).isdisjoint(secrets), "a Secret is both in the manifests and made by hand"
    secrets.update(made_by_hand)
    configmaps = {n: set((d.get("data") or {}) | (d.get("binaryData") or {})) for n, d in
                  by_kind(all_docs, "ConfigMap").items()}
    pvcs = set(by_kind(all_docs, "PersistentVolumeClaim"))
    accounts = set(by_kind(all_docs, "ServiceAccount"))
    used_secrets = set()
    for w in workloads(all_docs):
        spec, what = pod_spec(w), describe(w)
        sa = spec.get("serviceAccountName")
        if sa:
            assert sa in accounts, f"{what}: ServiceAccount {sa} is not in the manifests"
        volumes = {v["name"]: v for v in spec.get("volumes") or []}
        templates = {t["metadata"]["name"] for t in (w["spec"].get("volumeClaimTemplates") or [])}
        for v in volumes.values():
            if "secret" in v:
                assert v["secret"]["secretName"] in secrets, f"{what}: Secret {v['secret']['secretName']} unknown"
                used_secrets.add(v["secret"]["secretName"])
            if "configMap" in v:
                assert v["configMap"]["name"] in configmaps, f"{what}: ConfigMap {v['configMap']['name']} unknown"
            if "persistentVolumeClaim" in v:
                assert v["persistentVolumeClaim"]["claimName"] in pvcs, f"{what}: PVC unknown: {v}"
        for c in containers(spec):
            for m in c.get("volumeMounts") or []:
                assert m["name"] in volumes or m["name"] in templates, f"{what}: mount of unknown volume {m['name']}"
            for e in c.get("env") or []:
                ref = (e.get("valueFrom") or {}).get("secretKeyRef")
                if ref:
                    assert ref["name"] in secrets, (
                        f"{what}: Secret {ref['name']} is neither in the manifests nor made in deploy/README.md")
                    assert ref["key"] in secrets[ref["name"]], (
                        f"{what}: Secret {ref['name']} has no key {ref['key']} (has {sorted(secrets[ref['name']])})")
                    used_secrets.add(ref["name"])
                ref = (e.get("valueFrom") or {}).get("configMapKeyRef")
                if ref:
                    assert ref["name"] in configmaps and ref["key"] in configmaps[ref["name"]], f"{what}: {ref}"
            for e in c.get("envFrom") or []:
                if "secretRef" in e:
                    assert e["secretRef"]["name"] in secrets, f"{what}: {e}"
                    used_secrets.add(e["secretRef"]["name"])
                if "configMapRef" in e:
                    assert e["configMapRef"]["name"] in configmaps, f"{what}: {e}"
            # Kubernetes leaves an unknown $(VAR) in command and args as it is: every one must be defined.
            defined = {e["name"] for e in c.get("env") or []}
            for a in (c.get("command") or []) + (c.get("args") or []):
                for var in re.findall(r"(?<!\$)\$\(([A-Za-z_][A-Za-z0-9_]*)\)", str(a)):
                    assert var in defined, f"{what}: {c['name']} uses $({var}) but defines no such env var"
            for probe in ("readinessProbe", "livenessProbe", "startupProbe"):
                p = c.get(probe) or {}
                port = (p.get("httpGet") or p.get("tcpSocket") or p.get("grpc") or {}).get("port")
                if isinstance(port, str):
                    assert any(cp.get("name") == port for cp in c.get("ports") or []), f"{what}: {probe} port {port}"
    assert set(made_by_hand) <= used_secrets, f"deploy/README.md makes Secrets nothing uses: {made_by_hand}"


def test_images_are_pinned_with_an_explicit_pull_policy(all_docs):
    for w in workloads(all_docs):
        for c in containers(pod_spec(w)):
            name, tag, digest = split_image(c["image"])
            assert tag or digest, f"{describe(w)}: image {c['image']} has no tag (it would mean `latest`)"
            assert tag != "latest", f"{describe(w)}: image {c['image']} uses `latest`"
            assert c.get("imagePullPolicy") in {"IfNotPresent", "Always", "Never"}, (
                f"{describe(w)}: {c['name']} has no explicit imagePullPolicy")


def test_pods_are_locked_down_and_sized(all_docs):
    for w in workloads(all_docs):
        spec, what = pod_spec(w), describe(w)
        psc = spec.get("securityContext") or {}
        assert psc.get("runAsNonRoot") is True, f"{what}: runAsNonRoot"
        assert isinstance(psc.get("runAsUser"), int) and psc["runAsUser"] > 0, f"{what}: numeric non-root runAsUser"
        assert (psc.get("seccompProfile") or {}).get("type") == "RuntimeDefault", f"{what}: seccompProfile"
        assert spec.get("automountServiceAccountToken") is False, f"{what}: mounts an API token it does not need"
        assert isinstance(spec.get("terminationGracePeriodSeconds"), int), f"{what}: terminationGracePeriodSeconds"
        for c in containers(spec):
            sc = c.get("securityContext") or {}
            assert sc.get("allowPrivilegeEscalation") is False, f"{what}: {c['name']} allowPrivilegeEscalation"
            assert sc.get("readOnlyRootFilesystem") is True, f"{what}: {c['name']} readOnlyRootFilesystem"
            assert (sc.get("capabilities") or {}).get("drop") == ["ALL"], f"{what}: {c['name']} drops ALL"
            assert not (sc.get("capabilities") or {}).get("add"), f"{what}: {c['name']} adds capabilities"
            res = c.get("resources") or {}
            for part in ("requests", "limits"):
                for r in ("cpu", "memory"):
                    assert (res.get(part) or {}).get(r), f"{what}: {c['name']} has no {part}.{r}"
            if c.get("ports"):
                assert c.get("readinessProbe") and c.get("livenessProbe"), f"{what}: {c['name']} serves but has no probes"


def vb_container(docs, name):
    c = pod_spec(by_kind(docs, "Deployment")[name])["containers"][0]
    assert c["command"] == ["/bin/vb"], f"{name}: the image's entry point is /bin/vb"
    return c


def test_the_service_is_wired_as_the_code_expects(docs):
    deps = by_kind(docs, "Deployment")
    coord = deps["vb-coordinator"]
    assert coord["spec"]["replicas"] == 1 and coord["spec"]["strategy"]["type"] == "Recreate", (
        "exactly one coordinator (the store's only writer), never two during a rollout")
    c = vb_container(docs, "vb-coordinator")
    assert c["args"][0] == "coordinator" and "--db" in c["args"] and "--no-exec" in c["args"]
    listen = c["args"][c["args"].index("--listen") + 1]
    assert listen.startswith("0.0.0.0:"), "vb coordinator listens on 127.0.0.1 unless told otherwise"
    assert int(listen.rsplit(":", 1)[1]) in [p["containerPort"] for p in c["ports"]]

    lb = vb_container(docs, "vb-leaderboard")
    assert lb["args"][0] == "leaderboard" and "--db" in lb["args"]
    listen = lb["args"][lb["args"].index("--listen") + 1]
    assert listen.startswith("0.0.0.0:")
    port = int(listen.rsplit(":", 1)[1])
    assert port in [p["containerPort"] for p in lb["ports"]]
    ann = deps["vb-leaderboard"]["spec"]["template"]["metadata"].get("annotations") or {}
    assert ann.get("prometheus.io/scrape") == "true" and ann.get("prometheus.io/path") == "/metrics"
    assert ann.get("prometheus.io/port") == str(port), "the scrape port is the leaderboard's"

    w = vb_container(docs, "vb-worker")
    assert w["args"][0] == "worker" and "--no-exec" in w["args"], "worker pods cannot sandbox exec/image planners"
    url = w["args"][w["args"].index("--coordinator") + 1]
    m = re.fullmatch(r"http://([a-z0-9-]+):(\d+)", url)
    assert m, url
    svc = by_kind(docs, "Service").get(m.group(1))
    assert svc is not None, f"the workers' coordinator {url} is no Service"
    assert int(m.group(2)) in [p["port"] for p in svc["spec"]["ports"]]
    assert selects(svc["spec"]["selector"], pod_labels(coord))
    assert any(e["name"] == "VB_WORKER_TOKEN" and e["valueFrom"]["secretKeyRef"] for e in w["env"])


def test_workers_have_no_database_access(all_docs):
    worker = by_kind(all_docs, "Deployment")["vb-worker"]
    text = yaml.safe_dump(strip(worker))
    assert "--db" not in text and "postgres" not in text.lower(), "the worker Deployment mentions the database"
    for c in containers(pod_spec(worker)):
        for e in c.get("env") or []:
            ref = (e.get("valueFrom") or {}).get("secretKeyRef") or {}
            assert ref.get("name") != "vb-postgres", "workers must not get the store's Secret"
    policies = [np for np in by_kind(all_docs, "NetworkPolicy").values()
                if any(selects(np["spec"]["podSelector"], pod_labels(s))
                       for s in by_kind(all_docs, "StatefulSet").values())]
    assert policies, "no NetworkPolicy guards PostgreSQL"
    for np in policies:
        for rule in np["spec"]["ingress"]:
            for peer in rule.get("from") or []:
                assert "podSelector" in peer and "namespaceSelector" not in peer and "ipBlock" not in peer
                assert not selects(peer["podSelector"], pod_labels(worker)), "workers may reach PostgreSQL"


def test_deploy_readme_documents_the_kubernetes_steps():
    text = README.read_text()
    for s in ["kubectl apply -k deploy/k8s", "scale deployment/vb-worker --replicas=", "vb admin token create",
              "--role worker", "optional/worker-hpa.yaml", "--no-exec"]:
        assert s in text, f"deploy/README.md does not say `{s}`"
    assert set(readme_secrets()) == {"vb-postgres", "vb-worker-token"}, readme_secrets()


def test_the_rendering_matches_kubectl_kustomize(docs):
    kubectl = shutil.which("kubectl")
    if not kubectl:
        pytest.skip("SKIPPED: kubectl is not on the PATH (its built-in kustomize is compared with this renderer)")
    r = subprocess.run([kubectl, "kustomize", str(K8S)], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    theirs = {(d["kind"], d["metadata"]["name"]): d for d in yaml.safe_load_all(r.stdout) if d}
    ours = {(d["kind"], d["metadata"]["name"]): strip(d) for d in docs}
    assert set(theirs) == set(ours)
    for key, d in ours.items():
        assert d == theirs[key], f"{key}: this test's rendering differs from kubectl kustomize's"


def vb_help(vb, sub):
    r = subprocess.run([vb, sub, "--help"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, f"`vb {sub} --help` failed: {r.stderr}"
    return r.stdout


def test_vb_accepts_every_subcommand_and_flag_the_containers_use(all_docs):
    vb = os.environ.get("VB_BIN")
    if not vb:
        pytest.skip("SKIPPED: VB_BIN is not set (.ci/run sets it to the `vb` binary `cargo test` built); the "
                    "containers' vb subcommands and flags were not checked against `vb --help`")
    checked = 0
    for w in workloads(all_docs):
        for c in containers(pod_spec(w)):
            if c.get("command") != ["/bin/vb"]:
                continue
            args = c["args"]
            sub = args[0]
            help_text = vb_help(vb, sub)
            for a in args[1:]:
                if a.startswith("--"):
                    flag = a.split("=", 1)[0]
                    assert re.search(rf"(^|[\s,]){re.escape(flag)}([\s=<,]|$)", help_text, re.M), (
                        f"{describe(w)}: `vb {sub}` has no flag {flag}")
            for e in c.get("env") or []:
                # Variables that are not expanded into the arguments must be ones vb reads itself.
                if not any(f"$({e['name']})" in a for a in args):
                    # clap's `[env: NAME]`, or a variable vb reads itself and names in its help (a secret such as
                    # VB_WORKER_TOKEN, which must never be a flag's value on a command line).
                    assert (f"env: {e['name']}" in help_text
                            or f"environment variable {e['name']}" in " ".join(help_text.split())), (
                        f"{describe(w)}: `vb {sub}` reads no environment variable {e['name']}")
            checked += 1
    assert checked >= 3
    assert "env: VB_TASK_DIR" in vb_help(vb, "worker"), "the image's VB_TASK_DIR is what vb reads"
