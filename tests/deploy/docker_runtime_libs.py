#!/usr/bin/env python3
"""The image's runtime stage installs only the packages docker/Dockerfile names there (and what
they depend on): every shared library glintd and glint load must come from one of them, or the
container cannot start. (The image once shipped without cpp-httplib: "glintd: error while
loading shared libraries: libcpp-httplib.so.0.11".) Checked without a container, on the Debian
machine the binaries were built on: ldd for the libraries, dpkg -S for the package owning each,
apt-cache for the dependency closure of the runtime packages; packages of Priority "required"
are in every Debian image, debian:bookworm-slim included.

usage: docker_runtime_libs.py DOCKERFILE BINARY...   (exit 77: skipped, no apt package lists)
"""
import os
import re
import subprocess
import sys

SKIP = 77


def runtime_packages(dockerfile):
    """The packages of the `apt-get install` in the Dockerfile's last stage."""
    text = open(dockerfile, encoding="utf-8").read().replace("\\\n", " ")
    last_stage = re.split(r"^FROM\s", text, flags=re.M)[-1]
    packages = []
    for m in re.finditer(r"apt-get install([^&\n]*)", last_stage):
        packages += [t for t in m.group(1).split() if not t.startswith("-")]
    return packages


def closure(packages):
    out = subprocess.run(
        ["apt-cache", "depends", "--recurse", "--no-recommends", "--no-suggests", "--no-conflicts",
         "--no-breaks", "--no-replaces", "--no-enhances", "--no-pre-depends"] + packages,
        capture_output=True, text=True)
    if out.returncode != 0:
        print("apt-cache depends failed (no package lists? run apt-get update):", out.stderr.strip())
        sys.exit(SKIP)
    names = set()
    for line in out.stdout.splitlines():
        line = line.strip()
        if line.startswith("Depends:") or line.startswith("PreDepends:"):
            line = line.split(":", 1)[1].strip()
        names.add(line.strip("<>").split(":")[0])
    return names


def required_packages():
    out = subprocess.run(["dpkg-query", "-W", "-f=${Package} ${Priority}\\n"],
                         capture_output=True, text=True)
    return {l.split()[0] for l in out.stdout.splitlines() if l.endswith(" required")}


def owners(paths):
    """The installed package providing each path (usrmerge: /lib and /usr/lib are the same), by
    one dpkg -S over every spelling of every path."""
    spellings = {}
    for path in paths:
        real = os.path.realpath(path)
        for p in (path, real):
            spellings.setdefault(path, []).extend(
                [p, p[4:] if p.startswith("/usr/") else "/usr" + p])
    every = sorted({c for cs in spellings.values() for c in cs})
    out = subprocess.run(["dpkg", "-S"] + every, capture_output=True, text=True)
    by_path = {}
    for line in out.stdout.splitlines():
        pkgs, _, path = line.partition(": ")
        by_path[path.strip()] = pkgs.split(",")[0].split(":")[0].strip()
    return {p: next((by_path[c] for c in cs if c in by_path), None) for p, cs in spellings.items()}


def libraries(binary):
    out = subprocess.run(["ldd", binary], capture_output=True, text=True, check=True)
    libs = []
    for line in out.stdout.splitlines():
        m = re.search(r"=>\s*(/\S+)", line)
        if m:
            libs.append(m.group(1))
    return libs


def main():
    if len(sys.argv) < 3:
        print(__doc__)
        return 2
    dockerfile, binaries = sys.argv[1], sys.argv[2:]
    packages = runtime_packages(dockerfile)
    if not packages:
        print(f"{dockerfile}: no apt-get install in the last stage")
        return 1
    provided = closure(packages) | required_packages()
    missing = []
    for binary in binaries:
        libs = libraries(binary)
        owner = owners(libs)
        for lib in libs:
            pkg = owner[lib]
            if pkg is None:
                missing.append(f"{binary}: {lib} belongs to no Debian package")
            elif pkg not in provided:
                missing.append(f"{binary}: {lib} comes from {pkg}, which the runtime stage of "
                               f"{dockerfile} does not install (installs: {' '.join(packages)})")
    for m in missing:
        print(m)
    if not missing:
        print(f"every library of {len(binaries)} binaries is installed by the runtime stage "
              f"({len(packages)} packages, {len(provided)} with dependencies)")
    return 1 if missing else 0


if __name__ == "__main__":
    sys.exit(main())
