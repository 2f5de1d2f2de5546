#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# make -f Makefile.data install PREFIX=...: cmake --install into a staging folder first, then
# copy into PREFIX, so that a prefix that cannot be written is refused before anything is
# installed (nothing half-installed is left).
#   cmake/install_staged.sh BUILD_DIR PREFIX
set -euo pipefail
build=$1 prefix=$2
[[ -n $prefix ]] || { echo "install: PREFIX is empty" >&2; exit 2; }
[[ -f $build/cmake_install.cmake ]] || {
    echo "install: $build is not a configured build (make -f Makefile.data build first)" >&2
    exit 2
}
prefix=$(realpath -m "$prefix")
stage=$(mktemp -d)
trap 'rm -rf "$stage"' EXIT
DESTDIR=$stage cmake --install "$build" --prefix "$prefix" > "$stage.log" 2>&1 || {
    cat "$stage.log" >&2
    rm -f "$stage.log"
    exit 1
}
rm -f "$stage.log"
if ! mkdir -p "$prefix" 2> /dev/null || [[ ! -w $prefix ]]; then
    echo "install: cannot write to PREFIX $prefix: nothing was installed (choose a prefix" \
        "you can write, e.g. PREFIX=\$HOME/.local)" >&2
    exit 1
fi
cp -a "$stage$prefix/." "$prefix/"
echo "installed nebula into $prefix ($(find "$stage$prefix" -type f | wc -l) files)"
