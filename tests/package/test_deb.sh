#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The Debian package (cmake/NebulaPackage.cmake) built by CPack from this build: its control
# lists the shared libraries the tools load as dependencies, its contents are the tools,
# libnebula, the headers, the CMake and pkg-config packages, the man pages (gzipped) and bash
# completion; apt-get accepts it (a dry run, as root); unpacked into a scratch root (dpkg -x)
# the installed nebrender runs and prints the package's version, the one its changelog names
# (also in a build directory configured several commits before), and its copyright file
# names the licence (Apache-2.0).
#   test_deb.sh BUILD_DIR WORK
set -euo pipefail
build=$1 work=$2
command -v dpkg-shlibdeps > /dev/null || {
    echo "SKIP: dpkg-shlibdeps (dpkg-dev) is not installed" >&2
    exit 77
}
rm -rf "$work"
mkdir -p "$work"
(cd "$build" && cpack -G DEB -B "$work/out" > "$work/cpack.log" 2>&1) || {
    cat "$work/cpack.log" >&2
    exit 1
}
deb=$(ls "$work"/out/nebula_*_amd64.deb)
echo "built $(basename "$deb"): $(du -h "$deb" | cut -f1)"
dpkg-deb -I "$deb" > "$work/info.txt"
depends=$(dpkg-deb -f "$deb" Depends)
echo "Depends: $depends"
for lib in libopenvdb libtbb libopenexr libpng libcfitsio libhdf5 libc6; do
    [[ $depends == *"$lib"* ]] || { echo "FAIL: Depends lacks $lib" >&2; exit 1; }
done
version=$(dpkg-deb -f "$deb" Version)
dpkg-deb -c "$deb" > "$work/contents.txt"
for f in ./usr/bin/nebrender ./usr/bin/nebscatter ./usr/lib/libnebula_core.a \
    ./usr/include/nebula/render/fast.h ./usr/include/nebula/core/nebula_version.h \
    ./usr/lib/cmake/nebula/nebulaConfig.cmake ./usr/lib/pkgconfig/nebula.pc \
    ./usr/share/doc/nebula/CHANGELOG.md ./usr/share/man/man1/nebrender.1.gz \
    ./usr/share/bash-completion/completions/nebrender ./usr/share/doc/nebula/copyright; do
    grep -q " $f\$" "$work/contents.txt" || { echo "FAIL: the package lacks $f" >&2; exit 1; }
done
# apt accepts it: its dependencies resolve against this system (a dry run, nothing installed).
if [[ $(id -u) -eq 0 ]] && command -v apt-get > /dev/null; then
    apt-get install -s -qq "$deb" > "$work/apt.txt" 2>&1 || {
        cat "$work/apt.txt" >&2
        echo "FAIL: apt-get install -s $deb" >&2
        exit 1
    }
    grep -q "^Inst nebula " "$work/apt.txt" || { cat "$work/apt.txt" >&2; exit 1; }
fi
dpkg -x "$deb" "$work/root"
out=$("$work/root/usr/bin/nebrender" --version)
echo "$out"
[[ $out == "nebrender $version (OpenVDB "* ]] || {
    echo "FAIL: --version \"$out\" is not the package's version $version" >&2
    exit 1
}
# The licence: Debian's machine-readable copyright file, Apache-2.0 for every file.
copyright=$work/root/usr/share/doc/nebula/copyright
head -1 "$copyright" | grep -q "^Format: https://www.debian.org/doc/packaging-manuals/copyright-format/1.0/" &&
    grep -q "^License: Apache-2.0$" "$copyright" ||
    { echo "FAIL: $copyright is not a machine-readable Apache-2.0 copyright file" >&2; exit 1; }
first=$(gzip -dc "$work/root/usr/share/doc/nebula/changelog.gz" | head -1)
[[ $first == "nebula ($version) "* ]] || {
    echo "FAIL: the changelog's \"$first\" is not for the package's version $version" >&2
    exit 1
}
[[ $(PKG_CONFIG_PATH=$work/root/usr/lib/pkgconfig pkg-config --variable=includedir nebula) -ef \
    $work/root/usr/include ]] || { echo "FAIL: nebula.pc does not find the headers" >&2; exit 1; }
echo "package: $(basename "$deb") builds, depends on the runtime libraries, installs and runs"
