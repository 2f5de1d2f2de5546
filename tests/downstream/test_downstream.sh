#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Installs the build into a scratch prefix (cmake --install), builds tests/downstream against
# it twice (find_package(nebula CONFIG), and pkg-config nebula; both name the licence,
# Apache-2.0, as the copyright file installed beside the docs does), and checks that the program
# renders a small lit nebula as nebrender does (the same pixels to 1e-6 of the peak). Also:
# make -f Makefile.data install (cmake/install_staged.sh) into a prefix that cannot be written
# fails with a message and leaves nothing.
#   test_downstream.sh BUILD_DIR SOURCE_DIR WORK
set -euo pipefail
build=$1 src=$2 work=$3
rm -rf "$work"
mkdir -p "$work"
prefix=$work/prefix
cmake --install "$build" --prefix "$prefix" > "$work/install.log"
for f in bin/nebrender lib/libnebula_core.a include/nebula/core/version.h \
    include/nebula/core/nebula_version.h lib/cmake/nebula/nebulaConfig.cmake lib/pkgconfig/nebula.pc \
    share/doc/nebula/copyright; do
    [[ -e $prefix/$f ]] || { echo "FAIL: $prefix/$f not installed" >&2; exit 1; }
done
"$prefix/bin/nebrender" --version

# A small nebula, rendered by the installed nebrender.
"$prefix/bin/nebgen" --res 32 --seed 3 -o - | "$prefix/bin/nebillum" -i - -o "$work/lit.vdb"
"$prefix/bin/nebrender" -i "$work/lit.vdb" --res 96x64 -o "$work/ref.exr" --png none
# The renderer's defaults are 512x512: the downstream program renders that; so does this.
"$prefix/bin/nebrender" -i "$work/lit.vdb" -o "$work/ref512.exr" --png none

cmake -S "$src/tests/downstream" -B "$work/cmake-build" -DCMAKE_PREFIX_PATH="$prefix" \
    -DCMAKE_BUILD_TYPE=Release > "$work/configure.log"
cmake --build "$work/cmake-build" -j 2 > "$work/build.log"
"$work/cmake-build/downstream" "$work/lit.vdb" "$work/ref512.exr"

# pkg-config: the same program with the flags nebula.pc gives.
export PKG_CONFIG_PATH=$prefix/lib/pkgconfig
pkg-config --exists --print-errors nebula
[[ $(pkg-config --variable=license nebula) == Apache-2.0 ]] ||
    { echo "FAIL: nebula.pc's license is not Apache-2.0" >&2; exit 1; }
g++ -std=c++17 -O2 "$src/tests/downstream/main.cpp" -o "$work/downstream-pc" \
    $(pkg-config --cflags --libs nebula)
"$work/downstream-pc" "$work/lit.vdb" "$work/ref512.exr"

# A different image must not match (the comparison can fail).
if "$work/cmake-build/downstream" "$work/lit.vdb" "$work/ref.exr" > /dev/null 2>&1; then
    echo "FAIL: a 96x64 image matched the 512x512 render" >&2
    exit 1
fi

# make -f Makefile.data install into a prefix that cannot be written (/proc: not even root
# can): refused with a message naming it, exit 1, nothing installed.
if "$src/cmake/install_staged.sh" "$build" /proc/nebula-prefix > /dev/null 2> "$work/ro.log"; then
    echo "FAIL: install into /proc/nebula-prefix succeeded" >&2
    exit 1
fi
grep -q "cannot write to PREFIX /proc/nebula-prefix: nothing was installed" "$work/ro.log" ||
    { cat "$work/ro.log" >&2; exit 1; }
[[ ! -e /proc/nebula-prefix ]]
# The staged install itself, into a fresh prefix.
"$src/cmake/install_staged.sh" "$build" "$work/staged"
[[ -x $work/staged/bin/nebscatter && -f $work/staged/lib/cmake/nebula/nebulaTargets.cmake ]]
echo "downstream: installed package, CMake and pkg-config builds match nebrender"
