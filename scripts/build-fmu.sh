#!/usr/bin/env bash
# Builds the two FMI 2.0 co-simulation FMUs:
#
#   ./scripts/build-fmu.sh [OUT_DIR]        (default: out/fmu)
#
# writes OUT_DIR/hpctl_unit.fmu and OUT_DIR/hpctl_controller.fmu, each a zip
# with modelDescription.xml (generated from the Rust variable tables by
# hp-fmu-describe) and binaries/linux64/<modelIdentifier>.so (the one
# hp-fmu library, which serves both models: see docs/fmu.md). Needs cargo
# and python3 (its zipfile module packs the archives). The FMUs are
# written under a temporary name and renamed into place.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
out="${1:-$root/out/fmu}"
mkdir -p "$out"
out="$(cd "$out" && pwd)"

cd "$root"
cargo build --release --locked -p hp-fmu >&2
target="${CARGO_TARGET_DIR:-$root/target}/release"
case "$(uname -s)-$(uname -m)" in
    Linux-x86_64) platform=linux64 lib="$target/libhp_fmu.so" ;;
    *) echo "build-fmu.sh: only linux64 is built here (got $(uname -s)-$(uname -m))" >&2; exit 2 ;;
esac

stage="$(mktemp -d)"
trap 'rm -rf "$stage"' EXIT
for id in hpctl_unit hpctl_controller; do
    dir="$stage/$id"
    mkdir -p "$dir/binaries/$platform" "$dir/documentation"
    "$target/hp-fmu-describe" "$id" > "$dir/modelDescription.xml"
    cp "$lib" "$dir/binaries/$platform/$id.so"
    cp "$root/docs/fmu.md" "$dir/documentation/fmu.md"
    (cd "$dir" && python3 - "$out/.$id.fmu.tmp" <<'PY'
import os, sys, zipfile
with zipfile.ZipFile(sys.argv[1], "w", zipfile.ZIP_DEFLATED) as z:
    for base, _, files in sorted(os.walk(".")):
        for f in sorted(files):
            path = os.path.join(base, f)
            z.write(path, os.path.relpath(path, "."))
PY
    )
    mv -f "$out/.$id.fmu.tmp" "$out/$id.fmu"
    echo "$out/$id.fmu"
done
