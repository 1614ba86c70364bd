#!/usr/bin/env python3
"""Static checks of docker/ (no Docker engine or cluster runs on CI machines).

Usage: deploy_check.py PATH/TO/swell

- Every YAML file parses; the Dockerfile, compose file, nginx.conf and Kubernetes manifests agree
  with each other (ports, service names, secret keys, labels, grace periods).
- Every flag, subcommand and SWELL_* variable they use exists in `swell --help`,
  `swell serve --help` and `swell healthcheck --help` of the binary given.
- The example scenes (ConfigMap, compose) use ids that `swell scenes` does not list: a config
  scene with a built-in id replaces the built-in without a word.
- Dynamic where it is cheap: the image's HEALTHCHECK command runs against a real `swell serve`
  started with the ConfigMap's scenes TOML (exit 0) and against a closed port (exit 1); nginx
  checks docker/nginx.conf (`nginx -t`) with only the upstream and listen addresses substituted.
"""

import json
import os
import re
import shlex
import socket
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

import yaml

ROOT = Path(__file__).resolve().parent.parent
DOCKER = ROOT / "docker"
failures = []


def check(ok, what):
    if ok:
        print(f"  ok   {what}")
    else:
        print(f"  FAIL {what}")
        failures.append(what)


def help_text(swell, *args):
    return subprocess.run([swell, *args, "--help"], capture_output=True, text=True, check=True).stdout


def flags_of(text):
    return set(re.findall(r"(--[a-z][a-z0-9-]*)", text))


def envs_of(text):
    return set(re.findall(r"\[env: ([A-Z0-9_]+)[=\]]", text))


def subcommands_of(text):
    m = re.search(r"Commands:\n((?:  \S.*\n)+)", text)
    return {line.split()[0] for line in m.group(1).splitlines()} if m else set()


def argv_flags(argv):
    return {a.split("=", 1)[0] for a in argv if a.startswith("--")}


def free_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def port_of(addr):
    return int(str(addr).rsplit(":", 1)[1])


def seconds(v):
    v = str(v)
    if v.endswith("s"):
        return float(v[:-1])
    return float(v)


def main():
    swell = sys.argv[1]
    top, serve, hc = help_text(swell), help_text(swell, "serve"), help_text(swell, "healthcheck")
    serve_flags, serve_envs = flags_of(serve), envs_of(serve)
    hc_flags = flags_of(hc)
    subs = subcommands_of(top)
    print("swell:", sorted(subs), "serve env:", sorted(serve_envs))
    check({"serve", "healthcheck"} <= subs, "`swell serve` and `swell healthcheck` are subcommands")
    check("SWELL_STORE" in serve_envs and "--store" in serve_flags, "`swell serve` has --store / SWELL_STORE")

    # --- YAML parses
    docs = {}
    for f in [DOCKER / "compose.yaml", *sorted((DOCKER / "k8s").glob("*.yaml"))]:
        try:
            docs[f.name] = [d for d in yaml.safe_load_all(f.read_text()) if d is not None]
            check(True, f"{f.relative_to(ROOT)} parses")
        except yaml.YAMLError as e:
            check(False, f"{f.relative_to(ROOT)} parses: {e}")
    k8s = {}
    for name, ds in docs.items():
        for d in ds:
            if isinstance(d, dict) and "kind" in d and name != "compose.yaml":
                k8s[(d["kind"], d.get("metadata", {}).get("name", ""))] = d

    # --- Dockerfile
    df = (DOCKER / "Dockerfile").read_text()
    lines = re.sub(r"\\\n\s*", " ", df).splitlines()
    froms = [l.split()[1] for l in lines if l.startswith("FROM ")]
    builder = next((f for f in froms if f.startswith("rust:")), "")
    runtime = froms[-1] if froms else ""
    release = builder.rsplit("-", 1)[-1]
    check(release and runtime.startswith(f"debian:{release}"), f"runtime {runtime} is on the builder's Debian release ({builder})")
    check(any("cargo chef cook" in l for l in lines), "dependencies are cooked in their own layer (cargo-chef)")
    user = next((l.split()[1] for l in lines if l.startswith("USER ")), "root")
    check(user.split(":")[0] not in ("root", "0"), f"runs as a non-root user ({user})")
    env = {}
    for l in lines:
        if l.startswith("ENV "):
            for k, v in re.findall(r"([A-Z0-9_]+)=(\S+)", l):
                env[k] = v
    for k in env:
        if k.startswith("SWELL_"):
            check(k in serve_envs, f"Dockerfile ENV {k} is a `swell serve` variable")
    expose = [int(p.split("/")[0]) for l in lines if l.startswith("EXPOSE ") for p in l.split()[1:]]
    port = port_of(env.get("SWELL_BIND", ""))
    check(expose == [port], f"EXPOSE {expose} is the SWELL_BIND port {port}")
    hcl = next((l for l in lines if l.startswith("HEALTHCHECK ")), "")
    hc_argv = json.loads(hcl.split(" CMD ", 1)[1]) if " CMD " in hcl else []
    check(hc_argv[:2] == ["swell", "healthcheck"], f"HEALTHCHECK runs `swell healthcheck` ({hc_argv})")
    check(argv_flags(hc_argv) <= hc_flags, f"HEALTHCHECK flags {sorted(argv_flags(hc_argv))} exist")
    hc_url = hc_argv[hc_argv.index("--url") + 1] if "--url" in hc_argv else ""
    check(f":{port}/" in hc_url, f"HEALTHCHECK asks the served port ({hc_url})")
    cmd = next((json.loads(l.split(" ", 1)[1]) for l in lines if l.startswith("CMD ")), [])
    check(cmd[:1] == ["serve"] and argv_flags(cmd) <= serve_flags, f"CMD {cmd} is `swell serve`")

    # --- compose
    compose = docs.get("compose.yaml", [{}])[0]
    services = compose.get("services", {})
    swells = {n: s for n, s in services.items() if n.startswith("swell")}
    check(len(swells) == 3, f"compose runs three replicas ({sorted(swells)})")
    grace = []
    for n, s in swells.items():
        check(s["command"][0] == "serve" and argv_flags(s["command"]) <= serve_flags, f"compose {n} command flags exist")
        for k in s.get("environment", {}):
            if k.startswith("SWELL_"):
                check(k in serve_envs, f"compose {n} env {k} is a `swell serve` variable")
        check(port_of(s["environment"]["SWELL_BIND"]) == port, f"compose {n} listens on {port}")
        check(s["environment"].get("SWELL_STORE", "").startswith("redis://redis:6379"), f"compose {n} uses the redis service")
        shutdown = float(s["environment"].get("SWELL_SHUTDOWN_TIMEOUT", 10))
        grace.append(seconds(s.get("stop_grace_period", "10s")) > shutdown)
    check(grace and all(grace), "compose stop_grace_period exceeds the server's drain")
    redis_cmd = services.get("redis", {}).get("command", [])
    check("--appendonly" in redis_cmd and redis_cmd[redis_cmd.index("--appendonly") + 1] == "yes", "compose Redis has AOF on")
    check(any(str(v).endswith(":/data") for v in services.get("redis", {}).get("volumes", [])), "compose Redis keeps /data on a volume")

    subnets = [c.get("subnet") for c in compose.get("networks", {}).get("default", {}).get("ipam", {}).get("config", [])]
    compose_limits = tomllib.loads(compose.get("configs", {}).get("scenes", {}).get("content", "")).get("limits", {})
    check(subnets and all(n in compose_limits.get("trusted_proxies", []) for n in subnets),
          f"compose replicas trust nginx's network {subnets} for X-Forwarded-For ({compose_limits.get('trusted_proxies')})")

    # --- nginx.conf
    ngx = (DOCKER / "nginx.conf").read_text()
    upstream = re.findall(r"^\s*server\s+([\w.-]+):(\d+)", ngx, re.M)
    check(sorted(h for h, _ in upstream) == sorted(swells), f"nginx upstreams {upstream} are the compose replicas")
    check(all(int(p) == port for _, p in upstream), "nginx upstream ports are the served port")
    listen = re.findall(r"^\s*listen\s+(\d+);", ngx, re.M)
    nginx_ports = services.get("nginx", {}).get("ports", [])
    check(listen and all(str(p).endswith(f":{listen[0]}") for p in nginx_ports), f"nginx listens on the published port {listen}")
    check("proxy_set_header Upgrade $http_upgrade" in ngx and "$connection_upgrade" in ngx, "nginx passes WebSocket upgrades")
    check(re.search(r"proxy_read_timeout\s+(\d+)h", ngx) is not None, "nginx keeps streams open for hours")

    # --- Kubernetes
    dep = k8s.get(("Deployment", "swell"), {})
    spec = dep.get("spec", {})
    pod = spec.get("template", {}).get("spec", {})
    c = (pod.get("containers") or [{}])[0]
    check(spec.get("replicas") == 3, "Deployment runs 3 replicas")
    check(argv_flags(c.get("args", [])) <= serve_flags and c.get("args", [""])[0] == "serve", f"Deployment args {c.get('args')} exist")
    kenv = {e["name"]: e for e in c.get("env", [])}
    for k in kenv:
        if k.startswith("SWELL_"):
            check(k in serve_envs, f"Deployment env {k} is a `swell serve` variable")
    kport = port_of(kenv.get("SWELL_BIND", {}).get("value", ":0"))
    ports = {p.get("name"): p["containerPort"] for p in c.get("ports", [])}
    check(ports.get("http") == kport == port, f"containerPort http {ports} is SWELL_BIND's and the image's port")
    pport = port_of(kenv.get("SWELL_PROBE_BIND", {}).get("value", ":0"))
    check(ports.get("probes") == pport and pport != kport, f"containerPort probes {ports} is SWELL_PROBE_BIND's, apart from the served port")
    for probe, path in [("readinessProbe", "/readyz"), ("livenessProbe", "/healthz")]:
        g = c.get(probe, {}).get("httpGet", {})
        check(g.get("path") == path and ports.get(g.get("port"), g.get("port")) == pport, f"{probe} is GET {path} on the probe port (outside client limits)")
    routes = (ROOT / "src/api/mod.rs").read_text()
    check('"/readyz"' in routes and '"/healthz"' in routes, "the router serves /readyz and /healthz")
    check("requests" in c.get("resources", {}) and "limits" in c.get("resources", {}), "the container has resource requests and limits")
    drain = float(kenv.get("SWELL_SHUTDOWN_TIMEOUT", {}).get("value", 10))
    pre = c.get("lifecycle", {}).get("preStop", {}).get("exec", {}).get("command", [])
    pre_s = float(pre[-1]) if pre[:1] == ["sleep"] else 0.0
    tgp = pod.get("terminationGracePeriodSeconds", 30)
    check(tgp > drain + pre_s, f"terminationGracePeriodSeconds {tgp} > preStop {pre_s} + drain {drain}")
    check(pod.get("securityContext", {}).get("runAsNonRoot") is True, "pods run as non-root")
    ref = kenv.get("SWELL_ADMIN_TOKEN", {}).get("valueFrom", {}).get("secretKeyRef", {})
    sec = k8s.get(("Secret", ref.get("name", "")), {})
    check(ref.get("key") in sec.get("stringData", {}) or ref.get("key") in sec.get("data", {}), "the admin token comes from the Secret's key")
    store = kenv.get("SWELL_STORE", {}).get("value", "")
    m = re.match(r"redis://([\w.-]+):(\d+)/\d+$", store)
    rsvc = k8s.get(("Service", m.group(1) if m else ""), {})
    check(m is not None and any(p["port"] == int(m.group(2)) for p in rsvc.get("spec", {}).get("ports", [])), f"SWELL_STORE {store} is the Redis Service")
    sts = k8s.get(("StatefulSet", "swell-redis"), {})
    check(bool(sts.get("spec", {}).get("volumeClaimTemplates")), "Redis StatefulSet claims a volume")
    rargs = sts.get("spec", {}).get("template", {}).get("spec", {}).get("containers", [{}])[0].get("args", [])
    check("--appendonly" in rargs and rargs[rargs.index("--appendonly") + 1] == "yes", "Redis StatefulSet has AOF on")
    labels = spec.get("template", {}).get("metadata", {}).get("labels", {})
    svc = k8s.get(("Service", "swell"), {})
    check(svc.get("spec", {}).get("selector") == labels, "Service selects the Deployment's pods")
    check(all(ports.get(p["targetPort"], p["targetPort"]) == kport for p in svc.get("spec", {}).get("ports", [])), "Service targets the served port")
    hpa = k8s.get(("HorizontalPodAutoscaler", "swell"), {}).get("spec", {})
    check(hpa.get("scaleTargetRef", {}).get("name") == "swell" and hpa.get("minReplicas", 0) >= 3, "HPA scales the Deployment from 3")
    check(any(mm.get("resource", {}).get("name") == "cpu" for mm in hpa.get("metrics", [])), "HPA scales on CPU")
    pdb = k8s.get(("PodDisruptionBudget", "swell"), {}).get("spec", {})
    check(pdb.get("selector", {}).get("matchLabels") == labels, "PDB covers the Deployment's pods")
    mounts = {v["name"]: v["mountPath"] for v in c.get("volumeMounts", [])}
    cm_name = next((v["configMap"]["name"] for v in pod.get("volumes", []) if "configMap" in v), "")
    cm = k8s.get(("ConfigMap", cm_name), {}).get("data", {})
    cfg_path = c["args"][c["args"].index("--config") + 1] if "--config" in c.get("args", []) else ""
    cfg_key = Path(cfg_path).name
    check(cfg_key in cm and str(Path(cfg_path).parent) in mounts.values(), f"--config {cfg_path} is the ConfigMap's {cfg_key}")
    kfiles = yaml.safe_load((DOCKER / "k8s/kustomization.yaml").read_text()).get("resources", [])
    check(sorted(kfiles) == sorted(p.name for p in (DOCKER / "k8s").glob("*.yaml") if p.name != "kustomization.yaml"), "kustomization lists every manifest")

    # --- example scenes are extra scenes, not built-in ones replaced in silence (a config scene
    # with a built-in id overrides it, and the example then proves nothing)
    builtin = {line.split("\t")[0] for line in subprocess.run([swell, "scenes"], capture_output=True, text=True, check=True).stdout.splitlines() if line}
    check(len(builtin) >= 4, f"`swell scenes` lists the built-in scenes ({sorted(builtin)})")
    compose_toml = compose.get("configs", {}).get("scenes", {}).get("content", "")
    for where, text in [("the ConfigMap", cm.get(cfg_key, "")), ("compose's scenes config", compose_toml)]:
        ids = set(tomllib.loads(text).get("scenes", {}))
        check(ids and not ids & builtin, f"{where} defines scenes {sorted(ids)}, none of them built in")

    # --- dynamic: the ConfigMap's TOML loads, HEALTHCHECK works against a real server
    with tempfile.TemporaryDirectory() as tmp:
        toml_path = Path(tmp) / "scenes.toml"
        toml_path.write_text(cm.get(cfg_key, ""))
        tomllib.loads(toml_path.read_text())
        p = free_port()
        srv = subprocess.Popen(
            [swell, "serve", "--bind", f"127.0.0.1:{p}", "--config", str(toml_path), "--data-dir", f"{tmp}/data", "--admin-token", "x"],
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
        )
        try:
            argv = [swell if a == "swell" else a for a in hc_argv]
            argv = [a.replace(f":{port}/", f":{p}/") for a in argv]
            ok = False
            for _ in range(300):
                if subprocess.run(argv, capture_output=True).returncode == 0:
                    ok = True
                    break
                if srv.poll() is not None:
                    break
                time.sleep(0.1)
            check(ok, f"HEALTHCHECK command exits 0 against a server started with the ConfigMap's TOML ({shlex.join(argv[1:])})")
        finally:
            srv.terminate()
            try:
                srv.wait(timeout=20)
            except subprocess.TimeoutExpired:
                srv.kill()
        if srv.returncode not in (0, None) and not ok:
            print(srv.stderr.read() if srv.stderr else "")
        dead = subprocess.run(argv, capture_output=True)
        check(dead.returncode == 1, "HEALTHCHECK command exits 1 when nothing answers")

        # nginx -t with only the upstream and listen addresses substituted (as the fleet test).
        nginx = next((d + "/nginx" for d in os.environ.get("PATH", "").split(":") + ["/usr/sbin"] if os.path.exists(d + "/nginx")), None)
        if nginx:
            conf = re.sub(r"^(\s*server\s+)[\w.-]+:\d+", lambda m: f"{m.group(1)}127.0.0.1:{free_port()}", ngx, flags=re.M)
            conf = re.sub(r"^(\s*listen\s+)\d+;", lambda m: f"{m.group(1)}127.0.0.1:{free_port()};", conf, flags=re.M)
            (Path(tmp) / "nginx.conf").write_text(conf)
            (Path(tmp) / "temp").mkdir()
            t = subprocess.run([nginx, "-t", "-q", "-p", tmp, "-c", f"{tmp}/nginx.conf", "-g", f"pid {tmp}/nginx.pid;"], capture_output=True, text=True)
            check(t.returncode == 0, f"nginx -t accepts docker/nginx.conf {t.stderr.strip()}")
        else:
            check(False, "nginx is installed (apt-get install -y nginx)")

    if failures:
        print(f"deploy-check: {len(failures)} problem(s)")
        sys.exit(1)
    print("deploy-check: docker/ agrees with the binary")


if __name__ == "__main__":
    main()
