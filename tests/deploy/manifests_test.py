#!/usr/bin/env python3
"""The deployment files agree with each other, with deploy/README.md and with the binary.

Nothing here can be exercised for real on a machine without Docker or a cluster, so this checks
what a typo would break: every YAML file under deploy/ parses; the kustomize base lists files that
exist; the Deployment has its probes, resources and restrictive security context, a grace period
covering the drain, and agrees with the Service, HPA, PVC, PDB and ConfigMap; every ZOOMWARP_*
variable named anywhere in deploy/ is a real option (from `zoomwarp serve|ingest|health --help`);
the store path, port and uid are the same in the Dockerfile, compose.yaml and the k8s manifests;
the ConfigMap's thread counts and cache sizes fit the Deployment's resources; the probes' paths
are answered by the real binary as the probes need (liveness also while draining); nginx.conf
keeps its retry limits, the ones deploy/README.md states, and behaves by them in front of stand-in
upstreams on loopback (a request that kills its upstream kills at most two of three, a 503 is
passed on untried, a dead upstream is skipped), its cache directives and the lines tests/cluster
substitutes; the
Dockerfile's runtime stage is its base with the tree deploy/runtime-closure.sh gathers in the
builder (no package installed) and declares what a runtime image should; and deploy/README.md's
table of variables is exactly what --help says.

The deployments on a bucket (issue 29): the overlay deploy/k8s-s3, built as kustomize builds it
(a subset of kustomize here, compared with `kubectl kustomize` when kubectl is installed), has no
claim or shared volume, its store is an s3:// bucket, its credentials come from a Secret only, its
cache fits its volume and memory, its flags are options of the binary, and the rest is the base's;
deploy/compose.s3.yaml is compose.yaml's services but for the store, with no shared volume and the
bucket from an env file kept out of git; every AWS_ variable named is one tiles/s3_config.cc reads.

    python3 tests/deploy/manifests_test.py --binary build/bin/zoomwarp [--root .]
    python3 tests/deploy/manifests_test.py --binary build/bin/zoomwarp --readme-table  # regenerate

CTest runs it as deploy.manifests (label deploy). Needs PyYAML (Debian's python3-yaml).
"""
import argparse
import copy
import grp
import json
import os
import pwd
import re
import shlex
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import unittest
import urllib.error
import urllib.request

import yaml

ARGS = None  # filled in by main(): --binary, --root

# Options whose default is the machine's CPU count: --help shows this machine's number, the README
# says so in words.
CPU_DEPENDENT = {"io-threads": "half the number of CPUs (at least 1)", "workers": "number of CPUs",
                 "ingest-threads": "number of CPUs"}


# ---- reading the binary ---------------------------------------------------------------------------

HELP_COMMANDS = ("serve", "ingest", "health")
_HELP = {}


def help_text(command):
    """`zoomwarp COMMAND --help`. The first call starts all three at once: loading the binary's
    libraries takes a while on a busy machine, and this keeps the test at about a second."""
    if not _HELP:
        procs = {c: subprocess.Popen([ARGS.binary, c, "--help"], stdout=subprocess.PIPE, text=True)
                 for c in HELP_COMMANDS}
        for c, proc in procs.items():
            out, _ = proc.communicate(timeout=30)
            assert proc.returncode == 0, f"`zoomwarp {c} --help` exited {proc.returncode}"
            _HELP[c] = out
    return _HELP[command]


def help_options(command):
    """{option name: (variable, default or None, help text)} from `zoomwarp COMMAND --help`."""
    out = help_text(command)
    pattern = re.compile(r"^  --([a-z0-9-]+)(?: VALUE)?\s+(.*)\n\s+\[(ZOOMWARP_[A-Z0-9_]+)(?:; default (.*))?\]$",
                         re.MULTILINE)
    options = {m.group(1): (m.group(3), m.group(4), m.group(2).strip()) for m in pattern.finditer(out)}
    assert options, f"no options found in `zoomwarp {command} --help`:\n{out}"
    return options


_OPTIONS = {}


def options(command):
    if command not in _OPTIONS:
        _OPTIONS[command] = help_options(command)
    return _OPTIONS[command]


def variables(*commands):
    """{ZOOMWARP_X: default} over the given commands."""
    return {var: default for c in commands for var, default, _ in options(c).values()}


def default_of(var):
    return variables("serve", "ingest")[var]


# ---- reading the files ----------------------------------------------------------------------------

def path(*parts):
    return os.path.join(ARGS.root, *parts)


def read(*parts):
    with open(path(*parts), encoding="utf-8") as f:
        return f.read()


def load_yaml(*parts):
    docs = [d for d in yaml.safe_load_all(read(*parts)) if d is not None]
    assert len(docs) == 1, f"{os.path.join(*parts)}: expected one YAML document, found {len(docs)}"
    return docs[0]


def k8s_resources():
    """{kind: manifest} of the kustomize base, in deploy/k8s/kustomization.yaml's order."""
    kustomization = load_yaml("deploy", "k8s", "kustomization.yaml")
    out = {}
    for name in kustomization["resources"]:
        doc = load_yaml("deploy", "k8s", name)
        assert doc["kind"] not in out, f"two {doc['kind']}s in the base"
        out[doc["kind"]] = doc
    return out


def dockerfile_instructions():
    """[(INSTRUCTION, arguments)] with continuation lines joined and comments dropped."""
    lines, current = [], ""
    for raw in read("deploy", "Dockerfile").splitlines():
        stripped = raw.strip()
        if not current and (not stripped or stripped.startswith("#")):
            continue
        if current and stripped.startswith("#"):
            continue  # a comment inside a continued instruction
        if stripped.endswith("\\"):
            current += stripped[:-1] + " "
            continue
        current += stripped
        lines.append(current)
        current = ""
    out = []
    for line in lines:
        word, _, rest = line.partition(" ")
        out.append((word.upper(), rest.strip()))
    return out


def stages():
    """The Dockerfile's stages: [[(INSTRUCTION, arguments)], ...], each starting with its FROM."""
    result = []
    for ins in dockerfile_instructions():
        if ins[0] == "FROM":
            result.append([])
        assert result, "the Dockerfile must start with FROM"
        result[-1].append(ins)
    return result


def dockerfile_env(stage):
    env = {}
    for word, rest in stage:
        if word == "ENV":
            for item in shlex.split(rest):
                key, _, value = item.partition("=")
                env[key] = value
    return env


def duration_seconds(text):
    """Compose durations: 35s, 1m30s, 2m, 500ms."""
    total, pos = 0.0, 0
    for m in re.finditer(r"(\d+(?:\.\d+)?)(ms|us|h|m|s)", str(text)):
        assert m.start() == pos, f"unreadable duration {text!r}"
        total += float(m.group(1)) * {"h": 3600, "m": 60, "s": 1, "ms": 1e-3, "us": 1e-6}[m.group(2)]
        pos = m.end()
    assert pos == len(str(text)) and pos > 0, f"unreadable duration {text!r}"
    return total


def size_bytes(text):
    """512M, 512m, 1g, 1024 -> bytes (K, M, G as powers of 1024, as both zoomwarp and nginx read them)."""
    m = re.fullmatch(r"(\d+)([kKmMgG]?)", str(text).strip())
    assert m, f"unreadable size {text!r}"
    return int(m.group(1)) * {"": 1, "k": 1 << 10, "m": 1 << 20, "g": 1 << 30}[m.group(2).lower()]


def nginx_directives(text):
    """[(directive, arguments)] outside comments; block openings come as ('location', '~ ^/x {')."""
    out = []
    for statement in re.split(r"[;{}]\s*", re.sub(r"#[^\n]*", "", text)):
        words = statement.split(None, 1)
        if words:
            out.append((words[0], words[1] if len(words) > 1 else ""))
    return out


def nginx_block(text, opening):
    """The text of the first block whose opening line matches the regex `opening`, braces balanced."""
    text = re.sub(r"#[^\n]*", "", text)
    m = re.search(opening + r"\s*\{", text)
    assert m, f"nginx.conf: no block {opening!r}"
    depth, i = 1, m.end()
    while depth:
        depth += {"{": 1, "}": -1}.get(text[i], 0)
        i += 1
    return text[m.end():i - 1]


def nginx_binary():
    return shutil.which("nginx") or ("/usr/sbin/nginx" if os.path.exists("/usr/sbin/nginx") else None)


def nginx_conf_for(conf, upstreams, listen_port, var_dir):
    """deploy/nginx.conf as tests/cluster runs it (deploy/README.md, "Reusing nginx.conf"): one
    upstream line per address in `upstreams` (parameters kept), listening on 127.0.0.1, writing
    under var_dir."""
    def servers(m):
        return "".join(m.group(0).replace("zoomwarp:8080", a, 1) + "\n" for a in upstreams).rstrip("\n")
    conf = re.sub(r"^[ \t]*server[ \t]+zoomwarp:8080[^;]*;", servers, conf, count=1, flags=re.MULTILINE)
    conf = re.sub(r"^([ \t]*)listen[ \t]+8080;", rf"\1listen 127.0.0.1:{listen_port};", conf, count=1, flags=re.MULTILINE)
    return conf.replace("/var/cache/nginx", var_dir)


def nginx_globals(prefix):
    """The -g directives nginx.conf leaves to its caller (as tests/support/nginx.sh gives them): in
    the foreground, our pid file, and as root workers that run as the invoking user (as 'nobody'
    they could not enter a 0700 temp folder; nginx allows `user` only when started as root)."""
    globals_ = f"daemon off; pid {prefix}/nginx.pid;"
    if os.geteuid() == 0:
        globals_ += f" user {pwd.getpwuid(os.geteuid()).pw_name} {grp.getgrgid(os.getegid()).gr_name};"
    return globals_


def free_loopback_port():
    """A port nothing listens on now (the kernel's pick; another process could take it before use)."""
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def http_get(url, timeout=10):
    """(status, headers, body) of a GET; HTTP errors are answers too."""
    try:
        with urllib.request.urlopen(url, timeout=timeout) as r:
            return r.status, r.headers, r.read()
    except urllib.error.HTTPError as e:
        return e.code, e.headers, e.read()


def wait_for(condition, seconds, what):
    deadline = time.monotonic() + seconds
    while not condition():
        assert time.monotonic() < deadline, f"gave up waiting for {what}"
        time.sleep(0.05)


def dockerignore_excludes(rel):
    """Whether .dockerignore leaves `rel` (a path from the repository root) out of the build context."""
    patterns = []
    for line in read(".dockerignore").splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        negated = line.startswith("!")
        pat = os.path.normpath(line.lstrip("!").lstrip("/"))
        regex = ""
        i = 0
        while i < len(pat):  # Docker's rules: ** any number of folders, * and ? within one name
            if pat.startswith("**/", i):
                regex, i = regex + "(?:.*/)?", i + 3
            elif pat.startswith("**", i):
                regex, i = regex + ".*", i + 2
            elif pat[i] == "*":
                regex, i = regex + "[^/]*", i + 1
            elif pat[i] == "?":
                regex, i = regex + "[^/]", i + 1
            else:
                regex, i = regex + re.escape(pat[i]), i + 1
        patterns.append((negated, re.compile(regex + r"(?:/.*)?\Z")))  # a folder excludes its contents
    excluded = False
    for negated, regex in patterns:
        if regex.match(rel):
            excluded = not negated
    return excluded


# ---- the bucket deployments (issue 29): deploy/k8s-s3, deploy/compose.s3.yaml --------------------

S3_OVERLAY = ("deploy", "k8s-s3")
# The credentials among the AWS variables: only ever from a Secret or the env file, never written
# into a manifest.
AWS_CREDENTIALS = {"AWS_ACCESS_KEY_ID", "AWS_SECRET_ACCESS_KEY", "AWS_SESSION_TOKEN"}


def aws_variables():
    """The AWS_* variables the binary reads: the names tiles/s3_config.cc looks up."""
    names = set(re.findall(r'get\("(AWS_[A-Z0-9_]+)"\)', read("tiles", "s3_config.cc")))
    assert AWS_CREDENTIALS - {"AWS_SESSION_TOKEN"} <= names and "AWS_REGION" in names, \
        f"tiles/s3_config.cc no longer reads the variables this test expects: {sorted(names)}"
    return names


def value_options(command):
    """The options of `zoomwarp COMMAND` that take a value (`--name VALUE` in --help)."""
    return set(re.findall(r"^  --([a-z0-9-]+) VALUE", help_text(command), re.MULTILINE))


def command_flags(command, args, strict=False):
    """{option: value or None} of a command line's --options (args without the command word). An
    option `zoomwarp COMMAND --help` does not list fails with `strict`, else is taken to have a
    value (so that the other checks of a file can run with a binary that lacks a new flag)."""
    known, valued = options(command), value_options(command)
    out, i = {}, 0
    while i < len(args):
        word = args[i]
        i += 1
        if not word.startswith("--"):
            continue
        name, eq, value = word[2:].partition("=")
        assert name in known or not strict, (f"--{name} is not an option of `zoomwarp {command}` (its --help); "
                                             "a flag added on another branch must be in the binary tested")
        if not eq and (name in valued or name not in known):
            assert i < len(args), f"--{name} needs a value"
            value, i = args[i], i + 1
        out[name] = value if (eq or name in valued or name not in known) else None
    return out


def valid_bucket_name(b):
    """tiles/s3_config.cc valid_bucket_name, the same rules."""
    return (re.fullmatch(r"[a-z0-9][a-z0-9.-]{1,61}[a-z0-9]", b) is not None
            and not any(s in b for s in ("..", ".-", "-."))
            and not re.fullmatch(r"\d{1,3}(\.\d{1,3}){3}", b)
            and not b.startswith(("xn--", "sthree-")) and not b.endswith(("-s3alias", "--ol-s3")))


def s3_bucket(location):
    """The bucket of s3://BUCKET[/PREFIX], or None when `location` is not one the binary takes."""
    m = re.fullmatch(r"s3://([^/]*)(/.*)?", location or "")
    return m.group(1) if m and valid_bucket_name(m.group(1)) else None


def valid_endpoint(e):
    """tiles/s3_config.cc normalised_endpoint: http(s)://host[:port], an optional trailing '/'."""
    return re.fullmatch(r"https?://[^/?#@\s]+/?", e) is not None


# Strategic merge patches as kustomize applies them to the few kinds of field this repository's
# overlays patch; anything else is refused rather than guessed. Lists of objects with a merge key
# are merged item by item (`$patch: delete` removes one), the patch's items first and in its order,
# then the others in theirs (what kustomize v5 does); other lists are replaced; a null deletes.
SMP_MERGE_KEYS = {"containers": "name", "initContainers": "name", "volumes": "name",
                  "volumeMounts": "mountPath", "env": "name"}
SMP_REPLACED_LISTS = {"envFrom"}  # lists of objects the Kubernetes API gives no merge key


def smp_merge(base, patch, where="patch"):
    assert isinstance(base, dict) and isinstance(patch, dict), f"{where}: not an object"
    out = copy.deepcopy(base)
    for key, value in patch.items():
        assert not key.startswith("$"), f"{where}: {key} is not supported here"
        if value is None:
            out.pop(key, None)
        elif key in SMP_MERGE_KEYS and isinstance(value, list):
            out[key] = smp_merge_list(out.get(key, []), value, SMP_MERGE_KEYS[key], f"{where}.{key}")
        elif isinstance(value, dict) and isinstance(out.get(key), dict):
            out[key] = smp_merge(out[key], value, f"{where}.{key}")
        else:
            assert not (isinstance(value, dict) and any(k.startswith("$") for k in value)), f"{where}.{key}"
            assert not (isinstance(value, list) and any(isinstance(v, dict) for v in value)) \
                or key in SMP_REPLACED_LISTS, f"{where}.{key}: a list this test does not know how kustomize merges"
            out[key] = copy.deepcopy(value)
    return out


def smp_merge_list(base, patch, key, where):
    rest = copy.deepcopy(base)
    merged = []
    for item in patch:
        item = dict(item)
        directive = item.pop("$patch", None)
        assert directive in (None, "delete"), f"{where}: $patch: {directive} is not supported here"
        found = [i for i, b in enumerate(rest) if b.get(key) == item[key]]
        old = rest.pop(found[0]) if found else None
        if directive == "delete":
            continue
        merged.append(smp_merge(old, item, f"{where}[{item[key]}]") if old is not None else item)
    return merged + rest


def kustomize_python(folder):
    """[manifest] of the kustomization in `folder` (a path from the repository root), built with the
    subset of kustomize this repository uses: resources (files and folders), patches (strategic
    merge patches, `$patch: delete` of a whole resource included) and images."""
    k = load_yaml(folder, "kustomization.yaml")
    unknown = set(k) - {"apiVersion", "kind", "resources", "patches", "images"}
    assert not unknown, f"{folder}/kustomization.yaml: {sorted(unknown)} not supported by this test's build"
    docs = []
    for r in k.get("resources", []):
        rel = os.path.normpath(os.path.join(folder, r))
        docs += kustomize_python(rel) if os.path.isdir(path(rel)) else [load_yaml(rel)]
    for p in k.get("patches", []):
        assert set(p) == {"path"}, f"{folder}: only patches given by path are supported here: {p}"
        patch = load_yaml(folder, p["path"])
        target = (patch["kind"], patch["metadata"]["name"])
        hits = [i for i, d in enumerate(docs) if (d["kind"], d["metadata"]["name"]) == target]
        assert len(hits) == 1, f"{folder}/{p['path']}: patches {target}, found {len(hits)}"
        if patch.get("$patch") == "delete":
            del docs[hits[0]]
        else:
            body = {key: v for key, v in patch.items() if key not in ("apiVersion", "kind")}
            body["metadata"] = {key: v for key, v in patch["metadata"].items() if key != "name"}
            if not body["metadata"]:
                del body["metadata"]
            docs[hits[0]] = smp_merge(docs[hits[0]], body, f"{folder}/{p['path']}")
    for image in k.get("images", []):
        for d in docs:
            spec = d.get("spec", {}).get("template", {}).get("spec", {})
            for c in spec.get("containers", []) + spec.get("initContainers", []):
                if re.split(r"[:@]", c["image"])[0] == image["name"]:
                    c["image"] = f"{image.get('newName', image['name'])}:{image['newTag']}"
    return docs


def kustomize_kubectl(folder):
    """[manifest] of `kubectl kustomize FOLDER`, or None without kubectl."""
    kubectl = shutil.which("kubectl")
    if not kubectl:
        return None
    r = subprocess.run([kubectl, "kustomize", path(folder)], capture_output=True, text=True, timeout=30)
    assert r.returncode == 0, r.stderr
    return [d for d in yaml.safe_load_all(r.stdout) if d]


def by_kind(docs):
    out = {}
    for d in docs:
        assert d["kind"] not in out, f"two {d['kind']}s"
        out[d["kind"]] = d
    return out


def env_file(*parts):
    """{name: value} of a Compose env file: KEY=VALUE lines, '#' comments; quotes taken off."""
    out = {}
    for line in read(*parts).splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        key, eq, value = line.partition("=")
        assert eq and re.fullmatch(r"[A-Z_][A-Z0-9_]*", key), f"{os.path.join(*parts)}: not KEY=VALUE: {line!r}"
        value = value.strip()
        if len(value) >= 2 and value[0] == value[-1] and value[0] in "'\"":
            value = value[1:-1]
        out[key] = value
    return out


def placeholder(value):
    """A credential's value in a shipped example: something no store accepts, visibly."""
    return "REPLACE" in str(value).upper()


# ---- the checks -----------------------------------------------------------------------------------

class Files(unittest.TestCase):
    def test_every_yaml_file_under_deploy_parses(self):
        found = []
        for folder, _, files in os.walk(path("deploy")):
            for name in files:
                if name.endswith((".yaml", ".yml")):
                    rel = os.path.relpath(os.path.join(folder, name), ARGS.root)
                    with self.subTest(file=rel):
                        with open(os.path.join(folder, name), encoding="utf-8") as f:
                            docs = [d for d in yaml.safe_load_all(f) if d is not None]
                        self.assertTrue(docs, f"{rel} is empty")
                        for d in docs:
                            self.assertIsInstance(d, dict, rel)
                    found.append(rel)
        self.assertIn(os.path.join("deploy", "compose.yaml"), found)
        self.assertIn(os.path.join("deploy", "k8s", "kustomization.yaml"), found)

    def test_kustomization_lists_existing_files_and_every_manifest_of_the_base(self):
        k = load_yaml("deploy", "k8s", "kustomization.yaml")
        self.assertEqual(k["kind"], "Kustomization")
        listed = set(k["resources"])
        for name in listed:
            self.assertTrue(os.path.isfile(path("deploy", "k8s", name)), f"kustomization lists missing {name}")
        # A manifest left out of the list would silently not be deployed (examples/ is on purpose).
        present = {n for n in os.listdir(path("deploy", "k8s"))
                   if n.endswith(".yaml") and n != "kustomization.yaml"}
        self.assertEqual(present - listed, set(), "manifests in deploy/k8s/ that kustomization.yaml leaves out")
        kinds = set(k8s_resources())
        self.assertEqual(kinds, {"ConfigMap", "PersistentVolumeClaim", "Deployment", "Service",
                                 "HorizontalPodAutoscaler", "PodDisruptionBudget"})

    def test_kustomize_builds_the_base(self):
        kubectl = shutil.which("kubectl")
        if not kubectl:
            self.skipTest("kubectl not installed (its built-in kustomize renders the base)")
        r = subprocess.run([kubectl, "kustomize", path("deploy", "k8s")], capture_output=True, text=True, timeout=30)
        self.assertEqual(r.returncode, 0, r.stderr)
        kinds = [d["kind"] for d in yaml.safe_load_all(r.stdout) if d]
        self.assertEqual(len(kinds), 6, kinds)


class Kubernetes(unittest.TestCase):
    def setUp(self):
        self.r = k8s_resources()
        self.deployment = self.r["Deployment"]
        self.pod = self.deployment["spec"]["template"]
        self.container = self.pod["spec"]["containers"][0]
        self.config = self.r["ConfigMap"]["data"]

    def setting(self, var):
        """A variable's value in the ConfigMap, else the image's ENV, else the binary's default."""
        if var in self.config:
            return str(self.config[var])
        runtime_env = dockerfile_env(stages()[-1])
        return runtime_env.get(var, default_of(var))

    def test_probes(self):
        live, ready = self.container["livenessProbe"], self.container["readinessProbe"]
        self.assertEqual(live["httpGet"]["path"], "/healthz")
        self.assertEqual(ready["httpGet"]["path"], "/readyz")
        for probe in (live, ready):
            self.assertIn(probe["httpGet"]["port"], (8080, "http"))
        ports = {p.get("name"): p["containerPort"] for p in self.container["ports"]}
        self.assertEqual(list(ports.values()), [8080])
        self.assertEqual(ports.get("http"), 8080)

    def test_security_context(self):
        pod, c = self.pod["spec"].get("securityContext", {}), self.container["securityContext"]
        # Container fields win over the pod's; either place counts.
        merged = {**pod, **c}
        self.assertIs(merged.get("runAsNonRoot"), True)
        self.assertEqual(merged.get("runAsUser"), 10001)
        self.assertIs(c.get("readOnlyRootFilesystem"), True)
        self.assertIs(c.get("allowPrivilegeEscalation"), False)
        self.assertEqual(c.get("capabilities", {}).get("drop"), ["ALL"])
        self.assertEqual(merged.get("seccompProfile", {}).get("type"), "RuntimeDefault")
        self.assertEqual(pod.get("fsGroup"), 10001, "the store volume must be writable by uid 10001")
        user = [rest for word, rest in stages()[-1] if word == "USER"]
        self.assertEqual(user[-1].split(":")[0], str(merged["runAsUser"]), "Dockerfile USER vs runAsUser")

    def test_resources(self):
        res = self.container["resources"]
        for kind in ("requests", "limits"):
            for what in ("cpu", "memory"):
                self.assertIn(what, res.get(kind, {}), f"resources.{kind}.{what}")

    def test_threads_and_caches_fit_the_resources(self):
        # The thread defaults count the node's CPUs, not the pod's: each count must be set, and
        # match the CPU limit (server/README.md "Threads": I/O threads half of it, at least 1).
        res = self.container["resources"]
        cpus = int(str(res["limits"]["cpu"]))
        for var in ("ZOOMWARP_WORKERS", "ZOOMWARP_IO_THREADS", "ZOOMWARP_INGEST_THREADS"):
            self.assertIn(var, self.config, f"{var} defaults to the node's CPUs: set it to the pod's")
        self.assertEqual(int(self.config["ZOOMWARP_WORKERS"]), cpus, "workers vs the CPU limit")
        self.assertEqual(int(self.config["ZOOMWARP_IO_THREADS"]), max(1, cpus // 2), "I/O threads vs the CPU limit")
        self.assertLessEqual(int(self.config["ZOOMWARP_INGEST_THREADS"]), cpus, "ingest threads vs the CPU limit")
        # A warm pod holds its three caches: they fit the memory request, and the limit is above it.
        caches = sum(size_bytes(self.setting(v)) for v in ("ZOOMWARP_TILE_CACHE", "ZOOMWARP_RESPONSE_CACHE",
                                                             "ZOOMWARP_WARP_CACHE"))
        request, limit = (size_bytes(str(res[k]["memory"]).removesuffix("i")) for k in ("requests", "limits"))
        self.assertLessEqual(caches, request, "the caches do not fit the memory request")
        self.assertLess(request, limit)

    def test_grace_period_covers_the_drain(self):
        drain = int(self.setting("ZOOMWARP_DRAIN_DELAY")) + int(self.setting("ZOOMWARP_DRAIN_TIMEOUT"))
        grace = self.pod["spec"]["terminationGracePeriodSeconds"]
        self.assertGreaterEqual(grace, drain, "terminationGracePeriodSeconds < drain delay + drain timeout")
        # The drain delay is what keeps a stopping pod serving while endpoints update (no preStop).
        self.assertGreater(int(self.setting("ZOOMWARP_DRAIN_DELAY")), 0)

    def test_configuration_store_and_port(self):
        refs = [e["configMapRef"]["name"] for e in self.container.get("envFrom", [])]
        self.assertEqual(refs, [self.r["ConfigMap"]["metadata"]["name"]])
        self.assertEqual(self.container.get("args", [])[:1], ["serve"])
        self.assertEqual(self.setting("ZOOMWARP_PORT"), "8080")
        self.assertEqual(self.setting("ZOOMWARP_HOST"), "0.0.0.0")
        store = self.setting("ZOOMWARP_STORE")
        mounts = {m["mountPath"]: m["name"] for m in self.container["volumeMounts"]}
        self.assertIn(store, mounts, "the store path is not a mounted volume")
        volumes = {v["name"]: v for v in self.pod["spec"]["volumes"]}
        claim = volumes[mounts[store]]["persistentVolumeClaim"]["claimName"]
        self.assertEqual(claim, self.r["PersistentVolumeClaim"]["metadata"]["name"])
        # The root file system is read-only: every other writable path must be a volume too.
        self.assertIn("/tmp", mounts)

    def test_image_is_the_one_kustomize_sets(self):
        images = {i["name"]: i for i in load_yaml("deploy", "k8s", "kustomization.yaml")["images"]}
        self.assertIn(self.container["image"].split(":")[0], images)
        version = re.search(r"project\(zoomwarp VERSION ([0-9.]+)", read("CMakeLists.txt")).group(1)
        self.assertEqual(str(images[self.container["image"]]["newTag"]), version,
                         "kustomization.yaml's image tag is not this release (project VERSION in CMakeLists.txt)")

    def test_service(self):
        svc = self.r["Service"]["spec"]
        self.assertEqual([p["port"] for p in svc["ports"]], [8080])
        target = svc["ports"][0].get("targetPort", 8080)
        ports = {p.get("name"): p["containerPort"] for p in self.container["ports"]}
        self.assertEqual(ports.get(target, target), 8080)
        self.assertLessEqual(svc["selector"].items(), self.pod["metadata"]["labels"].items())

    def test_selectors(self):
        labels = self.pod["metadata"]["labels"]
        selector = self.deployment["spec"]["selector"]["matchLabels"]
        self.assertLessEqual(selector.items(), labels.items())
        pdb = self.r["PodDisruptionBudget"]
        self.assertEqual(pdb["apiVersion"], "policy/v1")
        self.assertLessEqual(pdb["spec"]["selector"]["matchLabels"].items(), labels.items(),
                             "the PodDisruptionBudget does not select the Deployment's pods")
        self.assertTrue({"minAvailable", "maxUnavailable"} & pdb["spec"].keys())

    def test_disruption_budget_leaves_a_pod_serving(self):
        pdb = self.r["PodDisruptionBudget"]["spec"]
        self.assertEqual(pdb.get("maxUnavailable"), 1, "voluntary disruptions take one pod at a time")
        self.assertLess(pdb["maxUnavailable"], self.r["HorizontalPodAutoscaler"]["spec"]["minReplicas"])

    def test_probes_restart_wedged_pods_not_busy_or_draining_ones(self):
        # Liveness on /healthz (the I/O threads answer it, never queued behind workers), patient
        # enough that a pod is restarted after several misses in a row, not one slow answer.
        live = self.container["livenessProbe"]
        self.assertGreaterEqual(live.get("failureThreshold", 3), 3)
        self.assertGreaterEqual(live["periodSeconds"] * live.get("failureThreshold", 3), 30)
        health_timeout = int(options("health")["timeout"][1])
        self.assertGreaterEqual(live["timeoutSeconds"], health_timeout, "as patient as the image's own health check")

    def test_hpa(self):
        hpa = self.r["HorizontalPodAutoscaler"]
        self.assertEqual(hpa["apiVersion"], "autoscaling/v2")
        ref = hpa["spec"]["scaleTargetRef"]
        self.assertEqual((ref["apiVersion"], ref["kind"], ref["name"]),
                         ("apps/v1", "Deployment", self.deployment["metadata"]["name"]))
        cpu = [m for m in hpa["spec"]["metrics"] if m["type"] == "Resource" and m["resource"]["name"] == "cpu"]
        self.assertTrue(cpu, "the HPA scales on CPU")
        self.assertLessEqual(hpa["spec"]["minReplicas"], hpa["spec"]["maxReplicas"])
        self.assertGreaterEqual(hpa["spec"]["minReplicas"], 2, "one replica cannot survive a disruption")
        self.assertNotIn("replicas", self.deployment["spec"], "the HPA owns the replica count")

    def test_pvc(self):
        self.assertIn("ReadWriteMany", self.r["PersistentVolumeClaim"]["spec"]["accessModes"])

    def test_keys_come_from_the_secret(self):
        # ZOOMWARP_KEYS names a file in a read-only mount of the Secret examples/keys-secret.yaml
        # shows; not a subPath mount, which would never see the Secret's updates (rotation).
        keys = self.config["ZOOMWARP_KEYS"]
        mount = [m for m in self.container["volumeMounts"] if keys.startswith(m["mountPath"].rstrip("/") + "/")]
        self.assertEqual(len(mount), 1, f"no volume mounted where {keys} lies")
        self.assertIs(mount[0].get("readOnly"), True)
        self.assertNotIn("subPath", mount[0])
        volume = {v["name"]: v for v in self.pod["spec"]["volumes"]}[mount[0]["name"]]
        example = load_yaml("deploy", "k8s", "examples", "keys-secret.yaml")
        self.assertEqual(example["kind"], "Secret")
        self.assertEqual(volume["secret"]["secretName"], example["metadata"]["name"])
        self.assertEqual(os.path.relpath(keys, mount[0]["mountPath"]), list(example["stringData"])[0])

    def test_ingest_job_example(self):
        job = load_yaml("deploy", "k8s", "examples", "ingest-job.yaml")
        self.assertEqual(job["kind"], "Job")
        spec = job["spec"]["template"]["spec"]
        c = spec["containers"][0]
        self.assertEqual(c["args"][0], "ingest")
        self.assertEqual(c["image"].split(":")[0], self.container["image"].split(":")[0])
        self.assertEqual(c["envFrom"], self.container["envFrom"])
        self.assertEqual(c["securityContext"], self.container["securityContext"])
        mounts = {m["mountPath"]: m["name"] for m in c["volumeMounts"]}
        volumes = {v["name"]: v for v in spec["volumes"]}
        store = self.setting("ZOOMWARP_STORE")
        self.assertEqual(volumes[mounts[store]]["persistentVolumeClaim"]["claimName"],
                         self.r["PersistentVolumeClaim"]["metadata"]["name"])


def deployment_files():
    """The deployment's configuration and its documentation under deploy/; not scripts, whose
    variables (ZOOMWARP_BINARY, say) are their own."""
    files = [os.path.join("deploy", n) for n in ("Dockerfile", "compose.yaml", "compose.s3.yaml", "s3.env.example",
                                                 "nginx.conf", "README.md")]
    for folder in (("deploy", "k8s"), S3_OVERLAY):
        files += [os.path.relpath(os.path.join(d, n), ARGS.root)
                  for d, _, names in os.walk(path(*folder)) for n in names if n.endswith(".yaml")]
    return files


class Variables(unittest.TestCase):
    def test_every_variable_in_deploy_is_a_real_option(self):
        known = set(variables("serve", "ingest", "health"))
        for rel in deployment_files():
            with self.subTest(file=rel):
                used = set(re.findall(r"ZOOMWARP_[A-Z0-9_]*[A-Z0-9]", read(rel)))
                self.assertEqual(used - known, set(), f"{rel} names variables no command has")

    def test_every_aws_variable_in_deploy_is_one_the_binary_reads(self):
        # The bucket store's configuration (docs/s3.md): a misspelt AWS_ variable is silently unread.
        known = aws_variables()
        for rel in deployment_files():
            with self.subTest(file=rel):
                used = set(re.findall(r"\bAWS_[A-Z0-9_]*[A-Z0-9]", read(rel)))
                self.assertEqual(used - known, set(), f"{rel} names AWS variables tiles/s3_config.cc does not read")

    def test_configured_variables_belong_to_serve_or_ingest(self):
        known = set(variables("serve", "ingest"))
        compose = load_yaml("deploy", "compose.yaml")["services"]["zoomwarp"].get("environment", {})
        sources = {
            "compose.yaml": set(compose),
            "k8s ConfigMap": set(k8s_resources()["ConfigMap"]["data"]),
            "Dockerfile ENV": set(dockerfile_env(stages()[-1])),
        }
        for name, used in sources.items():
            self.assertEqual(used - known, set(), f"{name} sets variables `serve` and `ingest` do not read")

    def test_readme_table_is_the_help_output(self):
        readme = read("deploy", "README.md")
        rows = {}
        for m in re.finditer(r"^\| `(ZOOMWARP_[A-Z0-9_]+)` \| `--([a-z0-9-]+)` \| ([^|]+) \| ([^|]*) \|", readme, re.MULTILINE):
            rows[m.group(1)] = (m.group(2), m.group(3).strip(), m.group(4).strip())
        expected = expected_table_rows()
        self.assertEqual(sorted(rows), sorted(expected),
                         "deploy/README.md's variable table differs from --help; regenerate it with "
                         "--readme-table:\n" + readme_table())
        for var, row in expected.items():
            self.assertEqual(rows[var], row, f"{var}: regenerate the table with --readme-table")


class Consistency(unittest.TestCase):
    """One store path, one port, one health check, one drain across the Dockerfile, compose and k8s."""

    def setUp(self):
        self.runtime = stages()[-1]
        self.env = dockerfile_env(self.runtime)
        self.compose = load_yaml("deploy", "compose.yaml")
        self.server = self.compose["services"]["zoomwarp"]
        self.k8s = k8s_resources()

    def test_store_path(self):
        store = self.env["ZOOMWARP_STORE"]
        volume = [rest for word, rest in self.runtime if word == "VOLUME"]
        self.assertEqual(volume, [store])
        compose_targets = [v.split(":")[1] for v in self.server["volumes"]]
        self.assertIn(store, compose_targets)
        self.assertEqual(self.server.get("environment", {}).get("ZOOMWARP_STORE", store), store)
        self.assertEqual(self.k8s["ConfigMap"]["data"].get("ZOOMWARP_STORE", store), store)
        mounts = [m["mountPath"] for m in self.k8s["Deployment"]["spec"]["template"]["spec"]["containers"][0]["volumeMounts"]]
        self.assertIn(store, mounts)
        # The store is a named volume shared by every replica, declared at the top level.
        name = [v.split(":")[0] for v in self.server["volumes"] if v.split(":")[1] == store][0]
        self.assertIn(name, self.compose.get("volumes", {}))

    def test_port(self):
        self.assertEqual(self.env["ZOOMWARP_PORT"], "8080")
        self.assertEqual([rest for word, rest in self.runtime if word == "EXPOSE"], ["8080"])
        self.assertEqual(str(self.server.get("environment", {}).get("ZOOMWARP_PORT", "8080")), "8080")
        self.assertEqual(str(self.k8s["ConfigMap"]["data"]["ZOOMWARP_PORT"]), "8080")
        conf = read("deploy", "nginx.conf")
        self.assertIn("server zoomwarp:8080 ", nginx_block(conf, r"upstream\s+zoomwarp"))
        nginx = self.compose["services"]["nginx"]
        self.assertEqual(nginx["ports"], ["8080:8080"])

    def test_compose(self):
        self.assertEqual(self.server["build"]["dockerfile"], "deploy/Dockerfile")
        self.assertTrue(os.path.isfile(path("deploy", self.server["build"]["context"], "deploy", "Dockerfile")))
        self.assertGreaterEqual(self.server.get("deploy", {}).get("replicas", 1), 2, "scale-out needs replicas")
        self.assertEqual(self.server["healthcheck"]["test"], ["CMD", "zoomwarp", "health"])
        env = self.server.get("environment", {})
        drain = int(env.get("ZOOMWARP_DRAIN_DELAY", default_of("ZOOMWARP_DRAIN_DELAY"))) + \
            int(env.get("ZOOMWARP_DRAIN_TIMEOUT", default_of("ZOOMWARP_DRAIN_TIMEOUT")))
        self.assertGreaterEqual(duration_seconds(self.server["stop_grace_period"]), drain,
                                "stop_grace_period < drain delay + drain timeout")
        health_timeout = int(options("health")["timeout"][1])
        self.assertGreater(duration_seconds(self.server["healthcheck"]["timeout"]), health_timeout,
                           "Docker would kill `zoomwarp health` before its own timeout reports")
        nginx = self.compose["services"]["nginx"]
        self.assertIn("./nginx.conf:/etc/nginx/nginx.conf:ro", nginx["volumes"])
        self.assertEqual(nginx["depends_on"]["zoomwarp"]["condition"], "service_healthy")

    def test_request_timeout_outlasts_nginx_retry_window(self):
        # A request that ran until its deadline on one replica must not be retried on another:
        # nginx retries only within proxy_next_upstream_timeout, which must end first.
        window = duration_seconds(dict(nginx_directives(read("deploy", "nginx.conf")))["proxy_next_upstream_timeout"])
        for name, env in (("compose.yaml", self.server.get("environment", {})), ("ConfigMap", self.k8s["ConfigMap"]["data"])):
            timeout = float(env.get("ZOOMWARP_REQUEST_TIMEOUT", default_of("ZOOMWARP_REQUEST_TIMEOUT")))
            self.assertLess(window, timeout, f"proxy_next_upstream_timeout vs ZOOMWARP_REQUEST_TIMEOUT in {name}")

    def test_keys_and_never_open_writes(self):
        # compose reads the keys from its secret; no deployment file lets anyone write.
        secret = self.server["environment"]["ZOOMWARP_KEYS"]
        self.assertTrue(secret.startswith("/run/secrets/"), secret)
        name = secret[len("/run/secrets/"):]
        self.assertIn(name, self.server.get("secrets", []))
        self.assertIn(name, self.compose.get("secrets", {}))
        self.assertIn("ZOOMWARP_KEYS", self.k8s["ConfigMap"]["data"])
        for source in (self.env, self.server.get("environment", {}), self.k8s["ConfigMap"]["data"]):
            self.assertNotIn("ZOOMWARP_OPEN_WRITES", source)

    def test_upload_limit(self):
        conf = read("deploy", "nginx.conf")
        uploads = nginx_directives(nginx_block(conf, r"location\s+~\s+\^/v1/images/\?\$"))
        limit = [args for d, args in uploads if d == "client_max_body_size"]
        self.assertEqual(len(limit), 1)
        for name, value in (("compose.yaml", self.server.get("environment", {}).get("ZOOMWARP_MAX_UPLOAD")),
                            ("ConfigMap", self.k8s["ConfigMap"]["data"].get("ZOOMWARP_MAX_UPLOAD"))):
            value = value or default_of("ZOOMWARP_MAX_UPLOAD")
            self.assertEqual(size_bytes(limit[0]), size_bytes(value),
                             f"nginx client_max_body_size for uploads vs ZOOMWARP_MAX_UPLOAD in {name}")
        self.assertIn(("proxy_request_buffering", "off"), uploads)


class Nginx(unittest.TestCase):
    def setUp(self):
        self.conf = read("deploy", "nginx.conf")
        self.directives = nginx_directives(self.conf)

    def values(self, name):
        return [args for d, args in self.directives if d == name]

    def value(self, name):
        found = self.values(name)
        self.assertEqual(len(found), 1, f"{name} once in nginx.conf")
        return found[0]

    def test_retries(self):
        # Only a replica that gave no answer is retried, on one other replica, early: a replica's
        # own answer (503 + Retry-After, 500) is final, and POST/PATCH are not retried once sent.
        self.assertEqual(self.value("proxy_next_upstream").split(), ["error", "timeout"])
        self.assertEqual(self.value("proxy_next_upstream_tries"), "2")
        window = duration_seconds(self.value("proxy_next_upstream_timeout"))
        self.assertGreater(window, duration_seconds(self.value("proxy_connect_timeout")),
                           "a connect timeout must leave time to try the next replica")

    def test_readme_states_the_retry_limits(self):
        # deploy/README.md's table ("Retries: what one bad request can cost") gives the values in force.
        readme = read("deploy", "README.md")
        rows = dict(re.findall(r"^\| `([a-z_]+)` \| `([^`]*)` \|", readme, re.MULTILINE))
        for name in ("proxy_next_upstream", "proxy_next_upstream_tries", "proxy_next_upstream_timeout"):
            self.assertEqual(rows.get(name), self.value(name), f"deploy/README.md's row for {name}")
        self.assertTrue(f"`{self.value('proxy_connect_timeout')}`" in readme, "proxy_connect_timeout in deploy/README.md")
        self.assertTrue(f"**At most {self.value('proxy_next_upstream_tries')} replicas**" in readme,
                        "deploy/README.md's count of replicas one request can crash")
        upstream = dict(nginx_directives(nginx_block(self.conf, r"upstream\s+zoomwarp")))
        params = upstream["server"].removeprefix("zoomwarp:8080 ")
        self.assertTrue(f"| `{params}` |" in readme, f"deploy/README.md's row for {params}")

    def test_cache(self):
        self.assertEqual(len(self.values("proxy_cache_path")), 1)
        self.assertIn("zoomwarp", self.values("proxy_cache"))
        self.assertIn("on", self.values("proxy_cache_revalidate"))
        self.assertIn("on", self.values("proxy_cache_lock"))
        self.assertTrue(any(a.startswith("X-Cache-Status $upstream_cache_status") for a in self.values("add_header")))
        # Our Cache-Control decides what is cached; a proxy_cache_valid would cache no-cache JSON.
        self.assertEqual(self.values("proxy_cache_valid"), [])
        self.assertEqual(self.values("proxy_ignore_headers"), [])

    def test_keyed_answers_are_cached_only_when_public(self):
        # The API key (Authorization) goes on to the replicas (no proxy_set_header replaces it), and
        # an answer to a keyed request is stored only when the replica marked it public.
        self.assertFalse([a for a in self.values("proxy_set_header") if a.lower().startswith("authorization")])
        self.assertFalse([a for a in self.values("proxy_pass_request_headers") if a == "off"])
        no_cache = self.values("proxy_no_cache")
        self.assertEqual(len(no_cache), 1, "proxy_no_cache")
        variable = no_cache[0]
        maps = re.findall(r"map\s+\"([^\"]*)\"\s+(\$\w+)", self.conf)
        self.assertIn(variable, [v for _, v in maps], f"{variable} is not a map's result")
        source = dict((v, k) for k, v in maps)[variable]
        self.assertIn("$http_authorization", source)

    def test_one_connection_per_upstream_request(self):
        # nginx gives back the try of a request failing on a reused upstream connection, so with
        # `keepalive` proxy_next_upstream_tries would not bound a request that crashes replicas.
        upstream = nginx_directives(nginx_block(self.conf, r"upstream\s+zoomwarp"))
        self.assertFalse([a for d, a in upstream if d.startswith("keepalive")], "no upstream keepalive")
        self.assertIn("Connection close", self.values("proxy_set_header"))

    def test_lines_tests_cluster_substitutes(self):
        # tests/cluster/cluster_test.sh rewrites exactly these (see nginx.conf's header comment).
        self.assertEqual(len(re.findall(r"^[ \t]*server[ \t]+zoomwarp:8080([ \t][^;]*)?;", self.conf, re.MULTILINE)), 1)
        self.assertEqual(len(re.findall(r"^[ \t]*listen[ \t]+8080;", self.conf, re.MULTILINE)), 1)
        paths = [a for d, a in self.directives if d.endswith("_path")]
        self.assertEqual(len(paths), 6, "the cache path and the five temp paths")
        for a in paths:
            self.assertTrue(a.startswith("/var/cache/nginx/"), a)
        for d in ("pid", "user", "daemon"):
            self.assertEqual(self.values(d), [], f"`{d}` is the caller's to set")

    def test_nginx_accepts_it(self):
        nginx = nginx_binary()
        if not nginx:
            self.skipTest("nginx not installed")
        with tempfile.TemporaryDirectory() as d:
            conf = re.sub(r"^([ \t]*)server[ \t]+zoomwarp:8080 ", r"\1server 127.0.0.1:8081 ", self.conf, flags=re.MULTILINE)
            conf = conf.replace("/var/cache/nginx", d)
            with open(os.path.join(d, "nginx.conf"), "w", encoding="utf-8") as f:
                f.write(conf)
            r = subprocess.run([nginx, "-t", "-q", "-p", d, "-e", "stderr", "-c", os.path.join(d, "nginx.conf"),
                                "-g", f"pid {d}/nginx.pid;"], capture_output=True, text=True, timeout=20)
            self.assertEqual(r.returncode, 0, r.stderr)


class Dockerfile(unittest.TestCase):
    def setUp(self):
        self.stages = stages()
        self.build, self.runtime = self.stages[0], self.stages[-1]

    def runs(self, stage):
        return " && ".join(rest for word, rest in stage if word == "RUN")

    def test_builder(self):
        self.assertEqual(len(self.stages), 2)
        self.assertRegex(self.build[0][1], r"^debian:bookworm\s+AS\s+\w+", "builder FROM")
        run = self.runs(self.build)
        self.assertIn("scripts/setup.sh --build-only", run)
        self.assertIn("-DBUILD_TESTING=OFF", run)
        self.assertIn("-DCMAKE_BUILD_TYPE=Release", run)
        self.assertIn("--target zoomwarp", run)
        setup = read("scripts", "setup.sh")
        self.assertIn("--build-only)", setup, "scripts/setup.sh has no --build-only")

    def test_builder_gathers_the_runtime_tree(self):
        # The closure is compared with the very image the runtime stage starts from.
        closure = re.search(r"--mount=type=bind,from=(\S+),target=(\S+)\s+deploy/runtime-closure\.sh --base (\S+) "
                            r"/build/bin/zoomwarp (\S+)$", self.runs(self.build))
        self.assertTrue(closure, "the builder runs deploy/runtime-closure.sh against the runtime base")
        image, target, base, tree = closure.groups()
        self.assertEqual(image, self.runtime[0][1])
        self.assertEqual(target, base)
        copies = [rest for word, rest in self.runtime if word == "COPY"]
        self.assertIn(f"--from={self.build[0][1].split()[-1]} {tree}/ /", copies)
        self.assertTrue(os.access(path("deploy", "runtime-closure.sh"), os.X_OK), "runtime-closure.sh not executable")
        # The builder has what runtime-files.txt lists: the face cascade comes from a build package.
        listed = [l.split("#")[0].strip() for l in read("deploy", "runtime-files.txt").splitlines()]
        listed = [l for l in listed if l]
        self.assertIn("/usr/share/opencv4/haarcascades/haarcascade_frontalface_default.xml", listed)
        for p in listed:
            self.assertRegex(p, r"^/\S+$", "one absolute path per line, '#' for comments")
        build_pkgs = re.search(r"^build_pkgs=\((.*?)^\)", read("scripts", "setup.sh"), re.MULTILINE | re.DOTALL)
        self.assertIn("opencv-data", re.sub(r"#.*", "", build_pkgs.group(1)).split())

    def test_runtime(self):
        self.assertEqual(self.runtime[0][1], "debian:bookworm-slim")
        copies = [rest for word, rest in self.runtime if word == "COPY"]
        self.assertTrue(any(c.startswith("--from=") and c.endswith("/usr/local/bin/zoomwarp") for c in copies))
        run = self.runs(self.runtime)
        self.assertNotIn("apt-get", run, "the runtime stage installs no package: the closure carries the libraries")
        self.assertTrue(run.startswith("ldconfig "), "the loader's cache is rebuilt after the closure is copied")

    def test_runtime_declarations(self):
        by = {}
        for word, rest in self.runtime:
            by.setdefault(word, []).append(rest)
        self.assertEqual(by.get("EXPOSE"), ["8080"])
        self.assertEqual(by.get("VOLUME"), ["/var/lib/zoomwarp"])
        self.assertEqual(by.get("STOPSIGNAL"), ["SIGTERM"])
        self.assertEqual(by.get("ENTRYPOINT"), ['["zoomwarp"]'])
        self.assertEqual(by.get("CMD"), ['["serve"]'])
        self.assertRegex(by["HEALTHCHECK"][0], r'CMD \["zoomwarp", "health"\]$')
        timeout = re.search(r"--timeout=(\S+)", by["HEALTHCHECK"][0])
        self.assertTrue(timeout)
        self.assertGreater(duration_seconds(timeout.group(1)), int(options("health")["timeout"][1]))
        user = by["USER"][-1].split(":")
        self.assertTrue(user[0].isdigit() and int(user[0]) != 0, "USER must be a numeric non-root uid")
        # Configuration by environment only, and only what a container changes.
        self.assertEqual(dockerfile_env(self.runtime),
                         {"ZOOMWARP_HOST": "0.0.0.0", "ZOOMWARP_PORT": "8080", "ZOOMWARP_STORE": "/var/lib/zoomwarp"})

    def test_dockerignore(self):
        for rel in (".git", "build", "build-deploy/bin/zoomwarp", "store", "tests/browser/node_modules",
                    "tests/browser/out", "deploy/compose.yaml", "deploy/keys"):
            self.assertTrue(dockerignore_excludes(rel), f".dockerignore should exclude {rel}")
        # Everything the Dockerfile copies and CMake builds from must stay in the context.
        needed = ["CMakeLists.txt", "scripts/setup.sh", "deploy/runtime-closure.sh", "deploy/runtime-files.txt"]
        for folder in ("cmake", "tiles", "warp", "api", "server", "web"):
            for d, _, names in os.walk(path(folder)):
                needed += [os.path.relpath(os.path.join(d, n), ARGS.root) for n in names]
        kept_out = [rel for rel in needed if dockerignore_excludes(rel)]
        self.assertEqual(kept_out, [], ".dockerignore leaves out files the image build needs")


class NginxBehaviour(unittest.TestCase):
    """nginx.conf in front of three stand-in upstreams (tests/deploy/standin_upstream.py) on
    loopback: what its retry policy does, seen in nginx's access log and in which stand-ins are
    still alive. One nginx worker process, so every request sees the upstream connections of the
    same worker (the only change made to the file besides those of "Reusing nginx.conf")."""

    def setUp(self):
        self.nginx = nginx_binary()
        if not self.nginx:
            self.skipTest("nginx not installed")
        self.dir = tempfile.mkdtemp(prefix="zoomwarp-nginx-test.")
        self.addCleanup(shutil.rmtree, self.dir, ignore_errors=True)
        self.upstreams = [self.start_upstream() for _ in range(3)]
        self.start_nginx()
        for i in range(12):  # every upstream has answered through nginx: connections a keepalive would keep
            self.assertEqual(self.get(f"/warm{i}")[0], 200)

    def start_upstream(self):
        proc = subprocess.Popen([sys.executable, path("tests", "deploy", "standin_upstream.py")],
                                stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
        self.addCleanup(self.stop, proc)
        return proc, int(proc.stdout.readline())

    def start_nginx(self):
        conf = nginx_conf_for(read("deploy", "nginx.conf"), [f"127.0.0.1:{port}" for _, port in self.upstreams],
                              free_loopback_port(), self.dir)
        conf = re.sub(r"^worker_processes\s+\S+;", "worker_processes 1;", conf, count=1, flags=re.MULTILINE)
        self.port = int(re.search(r"listen 127\.0\.0\.1:(\d+);", conf).group(1))
        with open(os.path.join(self.dir, "nginx.conf"), "w", encoding="utf-8") as f:
            f.write(conf)
        self.access_log = os.path.join(self.dir, "access.log")
        with open(self.access_log, "wb") as out, open(os.path.join(self.dir, "error.log"), "wb") as err:
            proc = subprocess.Popen([self.nginx, "-p", self.dir, "-e", "stderr", "-c", os.path.join(self.dir, "nginx.conf"),
                                     "-g", nginx_globals(self.dir)], stdout=out, stderr=err)
        self.addCleanup(self.stop, proc)

        def answers():
            try:
                socket.create_connection(("127.0.0.1", self.port), timeout=1).close()
                return True
            except OSError:
                assert proc.poll() is None, read(os.path.join(self.dir, "error.log"))
                return False
        wait_for(answers, 10, "nginx to listen")

    @staticmethod
    def stop(proc):
        if proc.poll() is None:
            proc.terminate()
            try:
                proc.wait(timeout=5)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()
        for stream in (proc.stdin, proc.stdout):
            if stream:
                stream.close()

    def get(self, target):
        return http_get(f"http://127.0.0.1:{self.port}{target}")

    def logged(self, target):
        """nginx's access log line of the request for `target` (written just after its answer)."""
        def lines():
            with open(self.access_log, encoding="utf-8") as f:
                return [line for line in map(json.loads, filter(str.strip, f)) if line["target"] == target]
        wait_for(lines, 5, f"nginx to log {target}")
        return lines()[-1]

    def alive(self):
        time.sleep(0.2)  # a stand-in that was sent /poison has exited by now
        return sum(proc.poll() is None for proc, _ in self.upstreams)

    def test_a_request_that_kills_its_upstream_costs_at_most_two(self):
        status, _, _ = self.get("/poison")
        self.assertEqual(status, 502)
        line = self.logged("/poison")
        self.assertEqual(len(line["upstream"].split(", ")), 2, line)
        self.assertEqual(self.alive(), 1, "stand-ins left alive of 3")
        self.assertEqual(self.get("/after")[0], 200, "the survivor answers")

    def test_a_replicas_503_is_passed_on_untried(self):
        status, headers, _ = self.get("/busy")
        self.assertEqual(status, 503)
        self.assertEqual(headers.get("Retry-After"), "1")
        self.assertEqual(len(self.logged("/busy")["upstream"].split(", ")), 1)

    def test_a_dead_upstream_is_skipped(self):
        proc, _ = self.upstreams[0]
        self.stop(proc)
        statuses = [self.get(f"/alive{i}")[0] for i in range(9)]
        self.assertEqual(statuses, [200] * 9)
        self.assertTrue(any("," in self.logged(f"/alive{i}")["upstream"] for i in range(9)),
                        "no request was retried on another upstream")


class Probes(unittest.TestCase):
    """The probes of deployment.yaml and compose.yaml against the real binary: its liveness and
    readiness paths on its port answer 200; while it drains (SIGTERM), readiness fails and liveness
    still passes, so a stopping pod leaves the Service without being killed."""

    def test_probe_paths_and_drain(self):
        container = k8s_resources()["Deployment"]["spec"]["template"]["spec"]["containers"][0]
        live, ready = (container[p]["httpGet"]["path"] for p in ("livenessProbe", "readinessProbe"))
        port = free_loopback_port()
        with tempfile.TemporaryDirectory() as store:
            server = subprocess.Popen([ARGS.binary, "serve", "--host", "127.0.0.1", "--port", str(port), "--store", store,
                                       "--drain-delay", "3", "--drain-timeout", "2", "--log-requests", "0"],
                                      stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            try:
                def status(target):
                    try:
                        return http_get(f"http://127.0.0.1:{port}{target}", timeout=3)[0]
                    except OSError:
                        assert server.poll() is None, server.stderr.read()
                        return None
                wait_for(lambda: status(live) is not None, 20, "zoomwarp serve to answer")
                # compose's healthcheck, `zoomwarp health`, on the port it reads from ZOOMWARP_PORT
                health = lambda: subprocess.run([ARGS.binary, "health"], env={**os.environ, "ZOOMWARP_PORT": str(port)},
                                                capture_output=True, timeout=10).returncode
                self.assertEqual((status(live), status(ready), health()), (200, 200, 0))
                server.send_signal(signal.SIGTERM)
                wait_for(lambda: status(ready) == 503, 2, "readiness to fail on SIGTERM")
                self.assertEqual((status(live), health()), (200, 0), "liveness while draining")
                self.assertEqual(server.wait(timeout=20), 0)
            finally:
                if server.poll() is None:
                    server.kill()
                    server.wait()
                server.stderr.close()


class S3Overlay(unittest.TestCase):
    """deploy/k8s-s3: the base on a bucket. Built with the kustomize subset above (always) and with
    `kubectl kustomize` when kubectl is installed, which must give the same manifests; then checked
    as a cluster would run it: no claim or shared volume at all, the store is the bucket, the
    credentials come from a Secret and nowhere else, the local cache fits its volume and memory,
    every flag is one `zoomwarp serve` has, and everything the overlay does not mean to change is
    the base's."""

    @classmethod
    def setUpClass(cls):
        cls.docs = kustomize_python(os.path.join(*S3_OVERLAY))
        cls.r = by_kind(cls.docs)
        cls.base = by_kind(kustomize_python(os.path.join("deploy", "k8s")))

    def setUp(self):
        self.deployment = self.r["Deployment"]
        self.pod = self.deployment["spec"]["template"]["spec"]
        self.container = self.pod["containers"][0]
        self.config = self.r["ConfigMap"]["data"]
        self.flags = command_flags("serve", self.container["args"][1:])

    def setting(self, var):
        """A variable's value in the overlay's ConfigMap, else the image's ENV, else the default."""
        if var in self.config:
            return str(self.config[var])
        return dockerfile_env(stages()[-1]).get(var, default_of(var))

    def volume_at(self, spec, container, mount_path):
        mounts = {m["mountPath"]: m["name"] for m in container["volumeMounts"]}
        self.assertIn(mount_path, mounts, f"no volume mounted at {mount_path}")
        return {v["name"]: v for v in spec["volumes"]}[mounts[mount_path]]

    def test_kubectl_kustomize_builds_the_same(self):
        built = kustomize_kubectl(os.path.join(*S3_OVERLAY))
        if built is None:
            self.skipTest("kubectl not installed: the overlay is checked as this test builds it")
        key = lambda d: (d["kind"], d["metadata"]["name"])
        self.assertEqual(sorted(map(key, built)), sorted(map(key, self.docs)))
        ours = {key(d): d for d in self.docs}
        for d in built:
            self.assertEqual(d, ours[key(d)], f"kubectl kustomize and this test build {key(d)} differently")

    def test_the_base_but_its_claim(self):
        self.assertEqual(set(self.r), set(self.base) - {"PersistentVolumeClaim"})
        # No volume any two pods could share: only emptyDirs and Secrets.
        for v in self.pod["volumes"]:
            self.assertLessEqual(set(v) - {"name"}, {"emptyDir", "secret"}, f"volume {v['name']}")
        self.assertNotIn("ReadWriteMany", yaml.safe_dump_all(self.docs))
        self.assertNotIn("persistentVolumeClaim", yaml.safe_dump_all(self.docs))

    def test_everything_the_overlay_does_not_mean_to_change_is_the_bases(self):
        for kind in ("Service", "HorizontalPodAutoscaler", "PodDisruptionBudget"):
            self.assertEqual(self.r[kind], self.base[kind], kind)
        base_config = self.base["ConfigMap"]["data"]
        changed = {k for k in base_config if self.config.get(k) != base_config[k]}
        self.assertEqual(changed, {"ZOOMWARP_STORE"}, "base settings the overlay changes")

        def rest(deployment):
            d = copy.deepcopy(deployment)
            spec = d["spec"]["template"]["spec"]
            c = spec["containers"][0]
            for field in ("args", "envFrom"):
                c.pop(field)
            c["resources"]["requests"] = {k: v for k, v in c["resources"]["requests"].items()
                                          if k not in ("memory", "ephemeral-storage")}
            c["volumeMounts"] = sorted((m for m in c["volumeMounts"] if m["mountPath"] != "/var/lib/zoomwarp"),
                                       key=lambda m: m["mountPath"])
            spec["volumes"] = sorted((v for v in spec["volumes"] if v["name"] not in ("store", "store-cache")),
                                     key=lambda v: v["name"])
            return d
        self.assertEqual(rest(self.deployment), rest(self.base["Deployment"]))
        # The base's configuration comes first; what follows adds to it.
        self.assertEqual(self.container["envFrom"][0], self.base["Deployment"]["spec"]["template"]["spec"]
                         ["containers"][0]["envFrom"][0])

    def test_the_store_is_the_bucket(self):
        store = self.setting("ZOOMWARP_STORE")
        self.assertIsNotNone(s3_bucket(store), f"ZOOMWARP_STORE={store!r} is not an s3://BUCKET/PREFIX the binary takes")
        self.assertEqual(self.container["args"][0], "serve")
        # One place says where the bucket is, the ConfigMap, which the ingest Job and a
        # `kubectl exec … zoomwarp` read too: a --store in serve's args would be a second one.
        self.assertNotIn("store", self.flags)
        self.assertNotIn("ZOOMWARP_STORE", {e["name"] for e in self.container.get("env", [])})
        self.assertEqual(self.setting("ZOOMWARP_PORT"), "8080")

    def test_flags_are_options_of_serve_and_ingest(self):
        # Fails on a flag `zoomwarp serve|ingest --help` does not list: the cache flags
        # (--store-cache, --store-cache-bytes, --store-memory-bytes) need a binary that has them.
        flags = command_flags("serve", self.container["args"][1:], strict=True)
        self.assertLessEqual({"store-cache", "store-cache-bytes", "store-memory-bytes"}, set(flags))
        job = load_yaml(*S3_OVERLAY, "examples", "ingest-job.yaml")["spec"]["template"]["spec"]["containers"][0]
        command_flags("ingest", job["args"][1:], strict=True)

    def test_the_cache_fits_its_volume(self):
        volume = self.volume_at(self.pod, self.container, self.flags["store-cache"])
        self.assertIn("emptyDir", volume, "the cache is the pod's own")
        self.assertNotEqual(volume["emptyDir"].get("medium"), "Memory", "the disk cache on disk")
        limit = size_bytes(volume["emptyDir"]["sizeLimit"].removesuffix("i"))
        # What the folder holds at most: the cache, the uploads staged until ingested, and the
        # pyramids being built (about twice an upload's size each: a lossy source is stored at a
        # higher quality, with the smaller levels on top). A pod past its sizeLimit is evicted.
        cache = size_bytes(self.flags["store-cache-bytes"])
        max_upload, staging = size_bytes(self.setting("ZOOMWARP_MAX_UPLOAD")), size_bytes(self.setting("ZOOMWARP_MAX_STAGING"))
        self.assertNotEqual(staging, 0, "ZOOMWARP_MAX_STAGING unset: the staged uploads have no bound")
        self.assertGreaterEqual(staging, max_upload, "the largest upload allowed could never be staged")
        pyramids = int(self.setting("ZOOMWARP_INGEST_WORKERS")) * 2 * max_upload
        self.assertGreaterEqual(limit, cache + staging + pyramids, "the cache volume's sizeLimit")
        requested = size_bytes(self.container["resources"]["requests"]["ephemeral-storage"].removesuffix("i"))
        self.assertGreaterEqual(requested, limit, "the node must have room for the cache volume")

    def test_the_caches_fit_the_memory_request(self):
        caches = sum(size_bytes(self.setting(v)) for v in ("ZOOMWARP_TILE_CACHE", "ZOOMWARP_RESPONSE_CACHE",
                                                             "ZOOMWARP_WARP_CACHE"))
        caches += size_bytes(self.flags["store-memory-bytes"])
        res = self.container["resources"]
        request, limit = (size_bytes(str(res[k]["memory"]).removesuffix("i")) for k in ("requests", "limits"))
        self.assertLessEqual(caches, request, "the four caches do not fit the memory request")
        self.assertLess(request, limit)

    def test_credentials_come_from_the_secret_only(self):
        secrets = [e["secretRef"]["name"] for e in self.container["envFrom"] if "secretRef" in e]
        example = load_yaml("deploy", "k8s", "examples", "s3-credentials-secret.yaml")
        self.assertEqual(example["kind"], "Secret")
        self.assertEqual(secrets, [example["metadata"]["name"]])
        self.assertFalse(self.container["envFrom"][-1].get("secretRef", {}).get("optional"), "pods must not start without it")
        keys = set(example.get("stringData", {})) | set(example.get("data", {}))
        self.assertLessEqual({"AWS_ACCESS_KEY_ID", "AWS_SECRET_ACCESS_KEY"}, keys)
        self.assertLessEqual(keys, AWS_CREDENTIALS, "the Secret holds credentials only")
        for k, v in example.get("stringData", {}).items():
            self.assertTrue(placeholder(v), f"examples/s3-credentials-secret.yaml: {k} is not a placeholder")
        # Nothing else carries them: not the overlay's output, the ConfigMap, or a literal env value.
        self.assertNotIn("Secret", self.r)
        self.assertEqual(set(self.config) & AWS_CREDENTIALS, set())
        for e in self.container.get("env", []):
            if e["name"] in AWS_CREDENTIALS:
                self.assertIn("secretKeyRef", e.get("valueFrom", {}), e["name"])

    def test_bucket_address_in_the_configmap(self):
        aws = {k: str(v) for k, v in self.config.items() if k.startswith("AWS_")}
        self.assertLessEqual(set(aws), aws_variables() - AWS_CREDENTIALS)
        self.assertRegex(aws.get("AWS_REGION", ""), r"^[a-z0-9-]{1,64}$")
        endpoint = aws.get("AWS_ENDPOINT_URL_S3", "")
        self.assertTrue(endpoint == "" or valid_endpoint(endpoint), f"AWS_ENDPOINT_URL_S3={endpoint!r}")

    def test_ingest_job_example(self):
        job = load_yaml(*S3_OVERLAY, "examples", "ingest-job.yaml")
        self.assertEqual(job["kind"], "Job")
        spec = job["spec"]["template"]["spec"]
        c = spec["containers"][0]
        self.assertEqual(c["args"][0], "ingest")
        flags = command_flags("ingest", c["args"][1:])
        # Same image (the release kustomize sets), settings, credentials and user as the servers.
        self.assertEqual(c["image"], self.container["image"])
        self.assertEqual(c["envFrom"], self.container["envFrom"])
        self.assertEqual(c["securityContext"], self.container["securityContext"])
        self.assertEqual(spec["securityContext"], self.pod["securityContext"])
        self.assertNotIn("store", flags, "the store is the ConfigMap's bucket")
        self.assertNotIn("ZOOMWARP_STORE", {e["name"] for e in c.get("env", [])})
        # No volume for the store; the staging and cache folder is an emptyDir holding its bound
        # and a pyramid.
        mounted = {m["name"] for m in c["volumeMounts"]}
        for v in spec["volumes"]:
            if v["name"] in mounted and "persistentVolumeClaim" in v:
                self.assertNotEqual(v["persistentVolumeClaim"]["claimName"], "zoomwarp-store")
        self.assertIn("store-cache", flags, "without it the pyramid is built under /tmp")
        volume = self.volume_at(spec, c, flags["store-cache"])
        self.assertIn("emptyDir", volume)
        limit = size_bytes(volume["emptyDir"]["sizeLimit"].removesuffix("i"))
        cache = size_bytes(flags.get("store-cache-bytes") or "0")
        self.assertGreaterEqual(limit, cache + 2 * size_bytes(self.setting("ZOOMWARP_MAX_UPLOAD")))
        self.assertGreaterEqual(size_bytes(c["resources"]["requests"]["ephemeral-storage"].removesuffix("i")), limit)

    def test_no_access_key_in_any_file(self):
        # Shapes of real AWS access key ids, in every file of the bucket deployments.
        files = [os.path.relpath(os.path.join(d, n), ARGS.root) for d, _, names in os.walk(path(*S3_OVERLAY)) for n in names]
        files += [os.path.join("deploy", n) for n in ("compose.s3.yaml", "s3.env.example")]
        files.append(os.path.join("deploy", "k8s", "examples", "s3-credentials-secret.yaml"))
        for rel in files:
            self.assertIsNone(re.search(r"\b(AKIA|ASIA)[0-9A-Z]{16}\b", read(rel)), rel)


class ComposeS3(unittest.TestCase):
    """deploy/compose.s3.yaml: compose.yaml's services with the store in a bucket. Its services
    must be compose.yaml's but for the store (so the two cannot drift), with no volume two replicas
    share, the bucket and credentials from the env file only, and the cache flags those of the
    Kubernetes overlay."""

    def setUp(self):
        self.compose = load_yaml("deploy", "compose.yaml")
        self.s3 = load_yaml("deploy", "compose.s3.yaml")
        self.server = self.s3["services"]["zoomwarp"]
        self.env = env_file("deploy", "s3.env.example")

    def test_the_services_are_compose_yamls_but_the_store(self):
        self.assertEqual(set(self.s3["services"]), set(self.compose["services"]))
        self.assertEqual(self.s3["services"]["nginx"], self.compose["services"]["nginx"])
        ours = {k: v for k, v in self.server.items() if k not in ("command", "env_file", "volumes")}
        theirs = {k: v for k, v in self.compose["services"]["zoomwarp"].items() if k != "volumes"}
        self.assertEqual(ours, theirs, "compose.s3.yaml's zoomwarp service differs from compose.yaml's")
        self.assertEqual(self.s3.get("secrets"), self.compose.get("secrets"))
        self.assertNotEqual(self.s3.get("name"), self.compose.get("name"), "one project's volumes would be the other's")

    def test_no_volume_is_shared(self):
        self.assertNotIn("volumes", self.s3, "a named volume would be shared by every replica")
        for v in self.server.get("volumes", []):
            if isinstance(v, str):
                self.assertNotIn(":", v, f"{v}: named or bound, so shared; an anonymous volume is a replica's own")
            else:
                self.assertEqual(v.get("type", "volume"), "volume", v)
                self.assertNotIn("source", v, v)

    def test_flags_are_options_of_serve(self):
        command_flags("serve", self.server["command"][1:], strict=True)

    def test_command_and_cache(self):
        command = self.server["command"]
        self.assertEqual(command[0], "serve")
        flags = command_flags("serve", command[1:])
        self.assertNotIn("store", flags, "the bucket comes from the env file")
        # The folder is a volume of each container's own, and the image's VOLUME, which the image
        # creates owned by uid 10001: anything else would be root's, and not writable.
        volume = [rest for word, rest in stages()[-1] if word == "VOLUME"]
        self.assertEqual([flags.get("store-cache")], volume)
        self.assertIn(flags["store-cache"], self.server["volumes"])
        # The same cache as the Kubernetes overlay's pods.
        container = by_kind(kustomize_python(os.path.join(*S3_OVERLAY)))["Deployment"]["spec"]["template"]["spec"]["containers"][0]
        k8s = command_flags("serve", container["args"][1:])
        for name in ("store-cache", "store-cache-bytes", "store-memory-bytes"):
            self.assertEqual(flags.get(name), k8s.get(name), f"--{name} in compose.s3.yaml vs deploy/k8s-s3")

    def test_bucket_and_credentials_from_the_env_file(self):
        self.assertEqual(self.server["env_file"], ["s3.env"])
        environment = self.server.get("environment", {})
        # `environment` wins over env_file: nothing there may hide the file's values.
        self.assertEqual({k for k in environment if k.startswith("AWS_") or k == "ZOOMWARP_STORE"}, set())
        self.assertIsNotNone(s3_bucket(self.env.get("ZOOMWARP_STORE")), "s3.env.example's ZOOMWARP_STORE")
        for k in ("AWS_ACCESS_KEY_ID", "AWS_SECRET_ACCESS_KEY"):
            self.assertTrue(placeholder(self.env.get(k)), f"s3.env.example: {k} is not a placeholder")
        known = set(variables("serve", "ingest")) | aws_variables()
        self.assertEqual(set(self.env) - known, set(), "s3.env.example sets variables nothing reads")
        mentioned = set(re.findall(r"\b(AWS_[A-Z0-9_]*[A-Z0-9])\b", read("deploy", "s3.env.example")))
        self.assertEqual(mentioned - aws_variables(), set(), "s3.env.example names AWS variables the binary ignores")
        endpoint = self.env.get("AWS_ENDPOINT_URL_S3", "")
        self.assertTrue(endpoint == "" or valid_endpoint(endpoint))

    def test_the_env_file_stays_out_of_git_and_the_image(self):
        ignored = [l.strip() for l in read("deploy", ".gitignore").splitlines() if l.strip() and not l.startswith("#")]
        self.assertTrue({"/s3.env", "s3.env"} & set(ignored), "deploy/.gitignore must ignore s3.env")
        self.assertTrue(dockerignore_excludes("deploy/s3.env"), ".dockerignore should exclude deploy/s3.env")


class S3Documentation(unittest.TestCase):
    def test_readme_and_docs_name_the_bucket_deployments(self):
        readme = read("deploy", "README.md")
        for name in ("compose.s3.yaml", "s3.env.example", "k8s-s3/", "examples/s3-credentials-secret.yaml",
                     "k8s-s3/examples/ingest-job.yaml"):
            self.assertTrue(f"`{name}`" in readme, f"deploy/README.md does not name {name}")
        s3 = read("docs", "s3.md")
        for doc in ("s3-operations.md", "../deploy/README.md"):
            self.assertTrue(f"({doc}" in s3, f"docs/s3.md does not link {doc}")
        self.assertTrue("(../docs/s3-operations.md" in readme, "deploy/README.md does not link docs/s3-operations.md")
        self.assertTrue(os.path.isfile(path("docs", "s3-operations.md")))


# ---- the README table -----------------------------------------------------------------------------

def expected_table_rows():
    """{variable: (flag, commands, default cell)} for every option of serve and ingest."""
    rows = {}
    for command in ("serve", "ingest"):
        for name, (var, default, _) in options(command).items():
            if var in rows:
                flag, commands, cell = rows[var]
                rows[var] = (flag, commands + ", " + command, cell)
                continue
            if name in CPU_DEPENDENT:
                cell = CPU_DEPENDENT[name]
            else:
                cell = f"`{default}`" if default else "—"
            rows[var] = (name, command, cell)
    return rows


def readme_table():
    helps = {var: h for c in ("serve", "ingest") for var, _, h in options(c).values()}
    lines = ["| variable | flag | commands | default | meaning |", "|---|---|---|---|---|"]
    for var, (flag, commands, cell) in expected_table_rows().items():
        lines.append(f"| `{var}` | `--{flag}` | {commands} | {cell} | {helps[var].replace('|', '/')} |")
    return "\n".join(lines)


def main():
    global ARGS
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--binary", required=True, help="the built zoomwarp")
    parser.add_argument("--root", default=os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", ".."),
                        help="the repository (default: two folders up from this file)")
    parser.add_argument("--readme-table", action="store_true",
                        help="print deploy/README.md's table of variables from the binary's --help, and exit")
    ARGS, rest = parser.parse_known_args()
    ARGS.root = os.path.abspath(ARGS.root)
    if ARGS.readme_table:
        print(readme_table())
        return 0
    result = unittest.main(argv=[sys.argv[0], "-v"] + rest, exit=False).result
    return 0 if result.wasSuccessful() else 1


if __name__ == "__main__":
    sys.exit(main())
