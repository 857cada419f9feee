#!/usr/bin/env bash
# Builds the container image `vertibench:local` from scratch (no base image, no registry): the release binaries
# `vb`, `vb-submit` and `example-planner`, the shared libraries they link (found with ldd), CA-free minimal /etc
# files and the committed task set, imported with `docker import`. The same image runs every part of the service.
#
#   deploy/build-image.sh            # builds the binaries (cargo build --release) and the image
set -euo pipefail
cd "$(dirname "$0")/.."
TARGET="${CARGO_TARGET_DIR:-target}"
cargo build --release --locked -p vb -p vb-submit -p example-planner
ROOT="$(mktemp -d)"
trap 'rm -rf "$ROOT"' EXIT
mkdir -p "$ROOT"/{bin,etc,tmp,data,opt/vertibench/tasks}
for b in vb vb-submit example-planner; do
    cp "$TARGET/release/$b" "$ROOT/bin/$b"
    strip "$ROOT/bin/$b" 2>/dev/null || true
    # Every shared library the binary needs, at the same path, plus the dynamic loader.
    ldd "$TARGET/release/$b" | grep -o '/[^ ]*' | while read -r lib; do
        mkdir -p "$ROOT$(dirname "$lib")"
        cp -L "$lib" "$ROOT$lib"
    done
done
cp -r tasks/data "$ROOT/opt/vertibench/tasks/data"
chmod 1777 "$ROOT/tmp"
echo "root:x:0:0:root:/:/bin/vb" > "$ROOT/etc/passwd"
echo "nobody:x:65534:65534:nobody:/:/bin/vb" >> "$ROOT/etc/passwd"
printf "root:x:0:\nnogroup:x:65534:\n" > "$ROOT/etc/group"
tar -C "$ROOT" -c . | docker import \
    -c 'ENV PATH=/bin' \
    -c 'ENV VB_TASK_DIR=/opt/vertibench/tasks/data/v4' \
    -c 'WORKDIR /data' \
    -c 'ENTRYPOINT ["/bin/vb"]' \
    - vertibench:local
docker image inspect --format 'built {{.RepoTags}} {{.Id}} ({{.Size}} bytes)' vertibench:local
