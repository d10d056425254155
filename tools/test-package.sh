#!/usr/bin/env bash
# Tests the Debian package (issue 49, part 3) end to end. Run as root (debootstrap, chroot, mounts).
#   1. builds it (tools/package.sh) and checks its contents, control fields and configuration;
#   2. checks the unit: `systemd-analyze verify`, and `systemd-analyze security --offline=yes`,
#      whose exposure level must be OK or better (the score is printed);
#   3. lintian: no error (warnings and notes are printed);
#   4. proves its Depends: a minimal bookworm chroot (debootstrap --variant=minbase from the Debian
#      mirror of this machine's apt sources; cached as a tarball under RV_CI_CACHE, default
#      /var/cache/rvoronoi-ci, with the downloaded packages), where
#      `apt-get install --no-install-recommends ./rvoronoi_….deb` must bring everything it needs;
#   5. in the chroot: the Python module computes, and the installed daemon runs with the packaged
#      configuration as the packaged user (no new privileges, no capabilities, umask 077 and no
#      writable executable memory as the unit says; in a network namespace of its own, so that
#      its port 8081 meets nothing of this machine) until it answers /health, the map page and
#      the README's synchronous job (HTTP 200, an ownership link whose GeoTIFF downloads);
#   6. stops it, purges the package, and checks that nothing of it remains but the system user.
# The chroot has no systemd as PID 1 (nor has CI): the unit's confinement itself is not exercised;
# step 2 checks what can be checked. Every mount and the namespace go on every exit path.
# Measured on the project's 2-core VM with the build tree built: about 50 s with the chroot cached
# (installing the package's 164 dependencies takes 35 of them), 85 s cold (debootstrap: 45 s).
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$PWD
cache=${RV_CI_CACHE:-/var/cache/rvoronoi-ci}
suite=bookworm

if [ "$(id -u)" -ne 0 ]; then
  echo "test-package: needs root (debootstrap, chroot, mounts)" >&2
  exit 1
fi

t0=$(date +%s)
step_start=$t0
step() {  # prints how long the previous step took, then names the next one
  local now
  now=$(date +%s)
  [ -z "${step_name:-}" ] || echo "test-package: ${step_name}: $((now - step_start)) s"
  step_name=$1
  step_start=$now
  [ -z "$1" ] || echo "test-package: ${1} ..."
}
fail() {
  echo "test-package: FAILED: $*" >&2
  exit 1
}

# The script's own output, for cleanup: a signal's trap may run inside a redirected function call.
exec 3>&1 4>&2
work=$(mktemp -d /tmp/rv-test-package.XXXXXX)
root=$work/chroot
netns=rvci$$
daemon_pid=
mounts=()
cleanup() {
  local rc=$?
  # Whatever still runs in the chroot (the daemon when a check failed): these processes are ours.
  local pid
  for pid in /proc/[0-9]*; do
    [ "$(readlink "$pid/root" 2>/dev/null)" != "$root" ] || kill -KILL "${pid#/proc/}" 2>/dev/null || true
  done
  [ -z "$daemon_pid" ] || wait "$daemon_pid" 2>/dev/null || true
  ip netns delete "$netns" 2>/dev/null || true
  local i
  for ((i = ${#mounts[@]} - 1; i >= 0; i--)); do
    umount "${mounts[$i]}" 2>/dev/null || umount -l "${mounts[$i]}" 2>/dev/null || true
  done
  # Never delete through a mount that is still there.
  if ! grep -q " $work/" /proc/mounts; then rm -rf "$work"; else echo "test-package: left $work (mounted)" >&4; fi
  echo "test-package: $([ $rc -eq 0 ] && echo passed || echo failed) in $(($(date +%s) - t0)) s" >&3
}
trap cleanup EXIT
trap 'exit 130' INT TERM

# ---------------------------------------------------------------------------------------------
step "tools"
need=()
command -v file >/dev/null || need+=(file)  # tools/package.sh (CPack's DEB generator)
command -v debootstrap >/dev/null || need+=(debootstrap)
command -v lintian >/dev/null || need+=(lintian)
command -v systemd-analyze >/dev/null || need+=(systemd)
command -v ip >/dev/null || need+=(iproute2)
command -v zstd >/dev/null || need+=(zstd)
command -v curl >/dev/null || need+=(curl)
if [ ${#need[@]} -gt 0 ]; then
  echo "test-package: installing ${need[*]}"
  DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${need[@]}" >/dev/null ||
    { apt-get update -q >/dev/null && DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends "${need[@]}" >/dev/null; }
fi

# ---------------------------------------------------------------------------------------------
step "package (tools/package.sh)"
bash tools/package.sh
debs=(dist/rvoronoi_*.deb)
[ ${#debs[@]} -eq 1 ] && [ -f "${debs[0]}" ] || fail "tools/package.sh made no single dist/rvoronoi_*.deb"
deb=$repo/${debs[0]}
version=$(dpkg-deb -f "$deb" Version)
arch=$(dpkg-deb -f "$deb" Architecture)
[ "$(basename "$deb")" = "rvoronoi_${version}_${arch}.deb" ] || fail "$(basename "$deb"): not rvoronoi_${version}_${arch}.deb"
cmake_version=$(sed -nE 's/^project\(rvoronoi VERSION ([0-9.]+).*/\1/p' CMakeLists.txt)
[ "$version" = "$cmake_version" ] || fail "package version $version is not project(VERSION) $cmake_version"

# ---------------------------------------------------------------------------------------------
step "contents"
dpkg-deb -c "$deb" | awk '{print $6}' | sed 's|^\./|/|' >"$work/contents"
for path in /usr/bin/rvoronoi \
  /usr/lib/python3/dist-packages/rvoronoi/__init__.py \
  /usr/lib/python3/dist-packages/rvoronoi/_dataset.py \
  /usr/share/rvoronoi/web/page.html /usr/share/rvoronoi/web/pages.js /usr/share/rvoronoi/web/client.js \
  /usr/share/rvoronoi/web/rvoronoi.css /usr/share/rvoronoi/web/app.html /usr/share/rvoronoi/web/app.js \
  /usr/share/rvoronoi/web/app.js.gz /usr/share/rvoronoi/web/app.css \
  /usr/share/man/man1/rvoronoi.1.gz \
  /etc/rvoronoi/serve.json \
  /lib/systemd/system/rvoronoi.service \
  /usr/share/doc/rvoronoi/copyright /usr/share/doc/rvoronoi/changelog.gz \
  /usr/share/doc/rvoronoi/examples/serve-config.example.json; do
  grep -qxF "$path" "$work/contents" || fail "the package has no $path"
done
grep -qE '^/usr/lib/python3/dist-packages/rvoronoi/_rvoronoi\.cpython-[0-9]+-.*\.so$' "$work/contents" ||
  fail "the package has no Python extension _rvoronoi"
[ "$(dpkg-deb -I "$deb" conffiles)" = "/etc/rvoronoi/serve.json" ] || fail "serve.json is not the one conffile"
depends=$(dpkg-deb -f "$deb" Depends)
for d in adduser 'python3 (>= ' python3-numpy python3-xarray libgdal; do
  [[ "$depends" == *"$d"* ]] || fail "Depends lacks $d: $depends"
done
echo "test-package: Depends: $depends"
mkdir "$work/pkg"
dpkg-deb -x "$deb" "$work/pkg"
python3 - "$work/pkg" <<'EOF'
import gzip, json, sys
root = sys.argv[1]
c = json.load(open(root + "/etc/rvoronoi/serve.json"))
assert c["web_dir"] == "/usr/share/rvoronoi/web", c
assert c["data_dir"].startswith("/var/lib/rvoronoi"), c
assert c["listen"] == "127.0.0.1:8081", c  # not tools/start.sh's 8080
man = gzip.open(root + "/usr/share/man/man1/rvoronoi.1.gz", "rt").read()
assert man.startswith(".TH RVORONOI 1") and "\\-\\-resolution" in man, man[:200]
EOF

# ---------------------------------------------------------------------------------------------
step "systemd unit"
# verify in the package's tree (its ExecStart and man page), with this machine's units beside it.
cp -rn /lib/systemd/system "$work/pkg/lib/systemd/"
if ! out=$(MANPATH=$work/pkg/usr/share/man systemd-analyze verify --root="$work/pkg" /lib/systemd/system/rvoronoi.service 2>&1) ||
  [ -n "$out" ]; then
  fail "systemd-analyze verify: $out"
fi
security=$(systemd-analyze security --offline=yes "$work/pkg/lib/systemd/system/rvoronoi.service" 2>&1 | grep 'Overall exposure level' || true)
echo "test-package: systemd-analyze security --offline=yes: ${security#*→ }"
[[ "$security" =~ :\ [0-9.]+\ (SAFE|OK) ]] || fail "exposure level worse than OK: $security"

# ---------------------------------------------------------------------------------------------
step "lintian"
lintian_rc=0
lintian --display-info --fail-on error "$deb" >"$work/lintian" 2>&1 || lintian_rc=$?
grep -v '^running with root privileges' "$work/lintian" || true
echo "test-package: lintian: $(grep -c '^E:' "$work/lintian" || true) errors, $(grep -c '^W:' "$work/lintian" || true) warnings, $(grep -c '^I:' "$work/lintian" || true) notes"
[ $lintian_rc -eq 0 ] || fail "lintian reports errors"

# ---------------------------------------------------------------------------------------------
step "chroot ($suite, minbase)"
# The Debian archive entries of this machine's apt sources (deb822 and one-line), for debootstrap's
# mirror and the chroot's sources.list: the same mirror, with its updates and security suites.
python3 - "$suite" >"$work/sources.list" <<'EOF'
import glob, re, sys
suite = sys.argv[1]
entries = []
for path in sorted(glob.glob("/etc/apt/sources.list.d/*.sources")):
    for block in re.split(r"\n\s*\n", open(path).read()):
        fields, key = {}, None
        for line in block.splitlines():
            if line.startswith("#") or not line.strip():
                continue
            if line[0].isspace() and key:
                fields[key] += " " + line.strip()
            elif ":" in line:
                key, value = line.split(":", 1)
                key = key.strip().lower()
                fields[key] = value.strip()
        if fields.get("enabled", "yes").lower() == "no" or "deb" not in fields.get("types", "").split():
            continue
        for uri in fields.get("uris", "").split():
            for s in fields.get("suites", "").split():
                entries.append((uri, s, fields.get("components", "main")))
for path in ["/etc/apt/sources.list"] + sorted(glob.glob("/etc/apt/sources.list.d/*.list")):
    try:
        lines = open(path).read().splitlines()
    except OSError:
        continue
    for line in lines:
        line = re.sub(r"\[[^]]*\]", "", line.split("#", 1)[0]).split()
        if len(line) >= 3 and line[0] == "deb":
            entries.append((line[1], line[2], " ".join(line[3:]) or "main"))
seen = set()
for uri, s, components in entries:
    if re.search(r"/debian(-security)?/?$", uri) and (s == suite or s.startswith(suite + "-") or s.startswith(suite + "/")):
        if (uri, s) not in seen:
            seen.add((uri, s))
            print("deb %s %s %s" % (uri.rstrip("/"), s, components))
EOF
mirror=$(awk -v s="$suite" '$3 == s {print $2; exit}' "$work/sources.list")
if [ -z "$mirror" ]; then
  mirror=http://deb.debian.org/debian
  echo "deb $mirror $suite main" >>"$work/sources.list"
  echo "test-package: no $suite entry in this machine's apt sources; using $mirror"
fi
tarball=$cache/$suite-minbase.tar.zst
mkdir -p "$cache/apt-archives/partial"
# A month-old chroot is made again (the archive moves on: point releases, security updates).
if [ -f "$tarball" ] && [ -n "$(find "$tarball" -mtime -30)" ]; then
  echo "test-package: chroot from $tarball"
else
  echo "test-package: debootstrap --variant=minbase $suite from $mirror (cached as $tarball)"
  mkdir "$work/boot"
  debootstrap --variant=minbase --keyring=/usr/share/keyrings/debian-archive-keyring.gpg \
    "$suite" "$work/boot" "$mirror" >"$work/debootstrap.log" 2>&1 ||
    { tail -20 "$work/debootstrap.log"; fail "debootstrap"; }
  rm -f "$work/boot"/etc/apt/sources.list.d/*
  cp "$work/sources.list" "$work/boot/etc/apt/sources.list"
  rm -rf "$work/boot/var/cache/apt/archives"/*.deb
  tar -C "$work/boot" --numeric-owner -cf - . | zstd -q -T0 -3 -o "$tarball.tmp"
  mv "$tarball.tmp" "$tarball"
  rm -rf "$work/boot"
fi
mkdir "$root"
zstd -q -dc "$tarball" | tar -C "$root" --numeric-owner -xpf -
cp "$work/sources.list" "$root/etc/apt/sources.list"
cp -L /etc/resolv.conf "$root/etc/resolv.conf"
# No service starts in the chroot (invoke-rc.d, deb-systemd-invoke); dpkg without fsync: a scratch tree.
printf '#!/bin/sh\nexit 101\n' >"$root/usr/sbin/policy-rc.d"
chmod 755 "$root/usr/sbin/policy-rc.d"
echo force-unsafe-io >"$root/etc/dpkg/dpkg.cfg.d/ci-unsafe-io"
mount -t proc proc "$root/proc" && mounts+=("$root/proc")
mount --bind /dev "$root/dev" && mounts+=("$root/dev")
mount --bind "$cache/apt-archives" "$root/var/cache/apt/archives" && mounts+=("$root/var/cache/apt/archives")
in_root() { chroot "$root" env -i PATH=/usr/sbin:/usr/bin:/sbin:/bin LANG=C.UTF-8 DEBIAN_FRONTEND=noninteractive "$@"; }
in_root dpkg-query -W -f='${Package}\n' | sort >"$work/before"
echo "test-package: the chroot has $(wc -l <"$work/before") packages"

# ---------------------------------------------------------------------------------------------
step "apt-get install ./$(basename "$deb") (its Depends only)"
cp "$deb" "$root/tmp/"
in_root apt-get update -q >"$work/apt.log" 2>&1 || { tail -20 "$work/apt.log"; fail "apt-get update in the chroot"; }
in_root apt-get install -y -q --no-install-recommends "/tmp/$(basename "$deb")" >>"$work/apt.log" 2>&1 ||
  { tail -30 "$work/apt.log"; fail "apt-get install of the package in the chroot"; }
echo "test-package: $(grep -c '^Setting up' "$work/apt.log") packages set up; what rvoronoi's postinst said:"
sed -n '/^Setting up rvoronoi /,/^\(Setting up\|Processing triggers\) /p' "$work/apt.log"
in_root getent passwd rvoronoi | grep -q ':/var/lib/rvoronoi:/usr/sbin/nologin$' || fail "no system user rvoronoi"
uid=$(in_root id -u rvoronoi)  # names on this machine's side are not the chroot's
[ "$(stat -c %u:%a "$root/var/lib/rvoronoi")" = "$uid:750" ] || fail "/var/lib/rvoronoi is not rvoronoi's, 0750"
[ -L "$root/etc/systemd/system/multi-user.target.wants/rvoronoi.service" ] || fail "the unit is not enabled"

# ---------------------------------------------------------------------------------------------
step "Python module in the chroot"
cp fixtures/demo_basepoints.geojson "$root/tmp/"
in_root python3 -c '
import rvoronoi
ds = rvoronoi.compute("/tmp/demo_basepoints.geojson", owner_field="state", resolution=200)
assert ds.owner.size > 0 and float(ds.distance.max()) > 0, ds
print("test-package: python3: rvoronoi", rvoronoi.__version__, dict(ds.sizes))
'

# ---------------------------------------------------------------------------------------------
step "daemon in the chroot"
ip netns add "$netns"
ip netns exec "$netns" ip link set lo up
in_ns() { ip netns exec "$netns" "$@"; }
# As the unit runs it: the packaged user, no new privileges, no capabilities, umask 077, no
# writable executable memory (the kernel's PR_SET_MDWE, which MemoryDenyWriteExecute= matches;
# where the kernel lacks it the daemon runs without).
cat >"$root/tmp/mdwe-exec.py" <<'EOF'
import ctypes, os, sys
if ctypes.CDLL(None, use_errno=True).prctl(65, 1, 0, 0, 0) != 0:  # PR_SET_MDWE, PR_MDWE_REFUSE_EXEC_GAIN
    print("test-package: no PR_SET_MDWE in this kernel (errno %d)" % ctypes.get_errno(), file=sys.stderr)
else:
    print("test-package: the daemon runs under PR_SET_MDWE", file=sys.stderr)
os.execv(sys.argv[1], sys.argv[1:])
EOF
ip netns exec "$netns" chroot "$root" env -i PATH=/usr/bin:/bin LANG=C.UTF-8 /bin/sh -c \
  'umask 077; exec setpriv --reuid=rvoronoi --regid=rvoronoi --init-groups --no-new-privs --bounding-set=-all \
     --inh-caps=-all -- python3 /tmp/mdwe-exec.py /usr/bin/rvoronoi serve --config /etc/rvoronoi/serve.json' \
  >"$work/daemon.log" 2>&1 &
daemon_pid=$!
base=http://127.0.0.1:8081
for _ in $(seq 1 100); do
  if in_ns curl -sf -o "$work/health.json" "$base/health"; then break; fi
  kill -0 "$daemon_pid" 2>/dev/null || { cat "$work/daemon.log"; fail "the daemon exited"; }
  sleep 0.2
done
[ -s "$work/health.json" ] || { cat "$work/daemon.log"; fail "no answer on $base/health"; }
[ "$(ps -o uid= -p "$daemon_pid" | tr -d ' ')" = "$uid" ] || fail "the daemon does not run as rvoronoi"
grep -q '^NoNewPrivs:[[:space:]]*1' "/proc/$daemon_pid/status" || fail "the daemon may gain privileges"
grep -q '^CapBnd:[[:space:]]*0000000000000000' "/proc/$daemon_pid/status" || fail "the daemon has capabilities"
grep -h '^test-package:' "$work/daemon.log" || true
echo "test-package: /health: $(head -c 200 "$work/health.json")"
# The pages' assets from /usr/share/rvoronoi/web (the configuration's web_dir).
[ "$(in_ns curl -s -o /dev/null -w '%{http_code}' "$base/app")" = 200 ] || fail "/app is not served"
[ "$(in_ns curl -s -o /dev/null -w '%{http_code}' "$base/static/app.js")" = 200 ] || fail "/static/app.js is not served"
# The README's synchronous job.
code=$(in_ns curl -s -o "$work/results.json" -w '%{http_code}' -X POST "$base/processes/voronoi/execution" \
  -H 'Content-Type: application/json' \
  -d "{\"inputs\": {\"seeds\": $(cat fixtures/demo_basepoints.geojson), \"ownerField\": \"state\", \"resolution\": 200}}")
[ "$code" = 200 ] || { cat "$work/results.json"; fail "the README's job: HTTP $code"; }
href=$(python3 -c '
import json, sys
doc = json.load(open(sys.argv[1]))
links = [l["href"] for l in doc.get("links", []) if "ownership" in l.get("href", "")]
links += [v["href"] for k, v in doc.items() if k == "ownership" and isinstance(v, dict) and "href" in v]
print(links[0] if links else "")' "$work/results.json")
[ -n "$href" ] || { cat "$work/results.json"; fail "no ownership link in the results"; }
in_ns curl -sf -o "$work/ownership.tif" "$href" || fail "GET $href"
[ "$(head -c 4 "$work/ownership.tif" | od -An -tx1 | tr -d ' ')" = 49492a00 ] || fail "$href is not a GeoTIFF"
echo "test-package: the README's job: HTTP 200, $href ($(stat -c %s "$work/ownership.tif") bytes)"
[ "$(stat -c %u "$root/var/lib/rvoronoi/jobs.sqlite")" = "$uid" ] || fail "the job store is not rvoronoi's"
kill -TERM "$daemon_pid"
daemon_rc=0
wait "$daemon_pid" || daemon_rc=$?
daemon_pid=
[ $daemon_rc -eq 0 ] || { cat "$work/daemon.log"; fail "the daemon exited with $daemon_rc on SIGTERM"; }

# ---------------------------------------------------------------------------------------------
step "apt-get purge"
in_root apt-get purge -y -q rvoronoi >"$work/purge.log" 2>&1 || { cat "$work/purge.log"; fail "apt-get purge"; }
if grep -E 'warning|not empty' "$work/purge.log"; then fail "dpkg warned while purging"; fi
[ -z "$(in_root dpkg-query -W -f='${Status}' rvoronoi 2>/dev/null)" ] || fail "dpkg still knows rvoronoi"
! in_root dpkg -L rvoronoi >/dev/null 2>&1 || fail "dpkg -L rvoronoi lists files"
for gone in /etc/rvoronoi /usr/share/rvoronoi /var/lib/rvoronoi /usr/lib/python3/dist-packages/rvoronoi \
  /usr/bin/rvoronoi /usr/share/doc/rvoronoi /lib/systemd/system/rvoronoi.service; do
  [ ! -e "$root$gone" ] || fail "$gone remains after the purge"
done
left=$(cd "$root" && find . -xdev -name '*rvoronoi*' ! -path './tmp/*' ! -path './proc/*' ! -path './dev/*')
[ -z "$left" ] || fail "left after the purge: $left"
in_root getent passwd rvoronoi >/dev/null || fail "the system user is gone (Debian keeps it)"
echo "test-package: purged; only the system user rvoronoi remains, as Debian keeps system users"
step ""
