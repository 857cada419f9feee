#!/usr/bin/env bash
# Builds a container image that serves a Python planner script, from scratch (no base image, no registry): this
# machine's Python interpreter and standard library, the `vertibench` SDK with its gRPC extra (built from ./python
# by pip, as users install it) and any extra packages, the shared libraries `ldd` names, and the script as
# /planner/planner.py, put together with `docker import`. The script must end with `serve(MyPlanner())`
# (vertibench.serve), which serves on $VB_PLANNER_ADDR as the worker sets it.
#
#   deploy/build-python-planner-image.sh examples/python/pure_pursuit.py my-planner:1 [PIP_PACKAGE...]
#   vb-submit image my-planner:1 --tasks low --wait
#
# PYTHON chooses the interpreter (default python3; its version must be 3.10 or later).
set -euo pipefail
[ $# -ge 2 ] || { sed -n '2,12p' "$0"; exit 2; }
script="$(realpath "$1")"
tag="$2"
shift 2
[ -f "$script" ] || { echo "no planner script $script" >&2; exit 2; }
cd "$(dirname "$0")/.."
py="${PYTHON:-python3}"
prefix="$("$py" -c 'import sys; print(sys.base_prefix)')"
ver="$("$py" -c 'import sys; print("%d.%d" % sys.version_info[:2])')"
exe="$("$py" -c 'import os, sys; print(os.path.realpath(sys.executable))')"
ROOT="$(mktemp -d)"
trap 'rm -rf "$ROOT"' EXIT
mkdir -p "$ROOT$prefix/bin" "$ROOT$prefix/lib" "$ROOT/planner" "$ROOT/tmp" "$ROOT/etc" "$ROOT/opt/site"
cp -L "$exe" "$ROOT$prefix/bin/python3"
# The standard library without its tests, GUI toolkits and installed packages.
tar -C "$prefix/lib" --exclude="python$ver/test" --exclude="python$ver/site-packages" --exclude="python$ver/idlelib" \
    --exclude="python$ver/tkinter" --exclude="python$ver/ensurepip" --exclude='__pycache__' -c "python$ver" \
    | tar -C "$ROOT$prefix/lib" -x
cp -L "$prefix"/lib/libpython"$ver"*.so* "$ROOT$prefix/lib/" 2>/dev/null || true
"$py" -m pip install -q --no-compile --target "$ROOT/opt/site" "./python[grpc]" "$@"
# Every shared library the interpreter and the extension modules need, at the same path, and the dynamic loader.
find "$ROOT" -type f \( -name '*.so' -o -name '*.so.*' -o -path "*/bin/python3" \) -print0 \
    | xargs -0 ldd 2>/dev/null | grep -o '/[^ ]*' | sort -u | while read -r lib; do
        case "$lib" in "$ROOT"*) continue ;; esac
        [ -e "$ROOT$lib" ] || { mkdir -p "$ROOT$(dirname "$lib")"; cp -L "$lib" "$ROOT$lib"; }
    done
cp "$script" "$ROOT/planner/planner.py"
chmod 1777 "$ROOT/tmp"
echo "nobody:x:65534:65534:nobody:/tmp:/bin/false" > "$ROOT/etc/passwd"
echo "nogroup:x:65534:" > "$ROOT/etc/group"
tar -C "$ROOT" -c . | docker import \
    -c "ENV PYTHONPATH=/opt/site" \
    -c "ENV PYTHONDONTWRITEBYTECODE=1" \
    -c "ENV HOME=/tmp" \
    -c "USER 65534" \
    -c "ENTRYPOINT [\"$prefix/bin/python3\", \"/planner/planner.py\"]" \
    - "$tag"
docker image inspect --format 'built {{.RepoTags}} {{.Id}} ({{.Size}} bytes)' "$tag"
