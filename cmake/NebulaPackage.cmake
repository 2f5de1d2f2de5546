# SPDX-License-Identifier: Apache-2.0
# Installation and packages (README "Install"):
#   cmake --install build --prefix ~/.local     the tools, their man pages and bash completion,
#                                               libnebula, its headers, the CMake
#                                               package (find_package(nebula CONFIG) gives
#                                               nebula::nebula) and nebula.pc
#   make -f Makefile.data deb                   nebula_<version>_amd64.deb (CPack)
# libnebula installs as its seven static layer libraries plus the interface target
# nebula::nebula that links them all: static, because the library's ABI is not stable yet
# (0.x) and a program linked against it then runs without it; the .deb's tools need no shared
# library of ours either. The tools need no data file at run time (the CIE tables and filter
# curves are compiled in).
include(CMakePackageConfigHelpers)

set(NEBULA_CMAKE_DIR ${CMAKE_INSTALL_LIBDIR}/cmake/nebula)

install(TARGETS nebgen nebillum nebionize nebscatter nebphase nebpyramid nebrender nebtone nebimport
                nebexport nebstats nebview
        RUNTIME DESTINATION ${CMAKE_INSTALL_BINDIR} COMPONENT tools)
foreach(tool IN LISTS NEBULA_TOOLS)
    install(FILES ${PROJECT_BINARY_DIR}/man/${tool}.1.gz DESTINATION ${CMAKE_INSTALL_MANDIR}/man1
            COMPONENT tools)
    install(FILES ${PROJECT_BINARY_DIR}/completion/${tool}
            DESTINATION ${CMAKE_INSTALL_DATADIR}/bash-completion/completions COMPONENT tools)
endforeach()
install(TARGETS nebula_core nebula_volume nebula_physics nebula_io nebula_render nebula_stages
                nebula_cli nebula
        EXPORT nebulaTargets
        ARCHIVE DESTINATION ${CMAKE_INSTALL_LIBDIR} COMPONENT dev)
install(DIRECTORY ${PROJECT_SOURCE_DIR}/libnebula/include/nebula
        DESTINATION ${CMAKE_INSTALL_INCLUDEDIR} COMPONENT dev FILES_MATCHING PATTERN "*.h"
        PATTERN "serve" EXCLUDE) # nebview's server: a tool's, not the library's API
install(FILES ${NEBULA_VERSION_HEADER} DESTINATION ${CMAKE_INSTALL_INCLUDEDIR}/nebula/core
        COMPONENT dev)
install(EXPORT nebulaTargets NAMESPACE nebula:: DESTINATION ${NEBULA_CMAKE_DIR} COMPONENT dev)
configure_package_config_file(${PROJECT_SOURCE_DIR}/cmake/nebulaConfig.cmake.in
                              ${CMAKE_CURRENT_BINARY_DIR}/nebulaConfig.cmake
                              INSTALL_DESTINATION ${NEBULA_CMAKE_DIR})
# 0.x: a minor version may break the API, so only the same minor version is compatible.
write_basic_package_version_file(${CMAKE_CURRENT_BINARY_DIR}/nebulaConfigVersion.cmake
                                 VERSION ${PROJECT_VERSION} COMPATIBILITY SameMinorVersion)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/nebulaConfig.cmake
              ${CMAKE_CURRENT_BINARY_DIR}/nebulaConfigVersion.cmake
        DESTINATION ${NEBULA_CMAKE_DIR} COMPONENT dev)
# nebula.pc is relocatable: its prefix is found from where the file is (${pcfiledir}), so
# cmake --install --prefix P and the .deb's /usr both work.
file(RELATIVE_PATH NEBULA_PC_UP /p/${CMAKE_INSTALL_LIBDIR}/pkgconfig /p)
configure_file(${PROJECT_SOURCE_DIR}/cmake/nebula.pc.in ${CMAKE_CURRENT_BINARY_DIR}/nebula.pc
               @ONLY)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/nebula.pc
        DESTINATION ${CMAKE_INSTALL_LIBDIR}/pkgconfig COMPONENT dev)
install(FILES ${PROJECT_SOURCE_DIR}/README.md ${PROJECT_SOURCE_DIR}/CHANGELOG.md
        DESTINATION ${CMAKE_INSTALL_DOCDIR} COMPONENT tools)
# The licence (LICENSE: Apache-2.0) as Debian's machine-readable copyright file, where a .deb
# keeps it (/usr/share/doc/nebula/copyright); it points at the system's copy of the full text
# (/usr/share/common-licenses/Apache-2.0), as Debian policy 12.5 asks.
install(FILES ${PROJECT_SOURCE_DIR}/cmake/debian-copyright DESTINATION ${CMAKE_INSTALL_DOCDIR}
        RENAME copyright COMPONENT tools)
# Debian's changelog.gz of a native package, pointing at CHANGELOG.md, for the version the
# build wrote into its version header (rewritten when git describe changes; gzip -n).
add_custom_command(OUTPUT ${CMAKE_CURRENT_BINARY_DIR}/changelog.gz
    COMMAND ${CMAKE_COMMAND} -DHEADER=${NEBULA_VERSION_HEADER} -DOUTPUT=debian-changelog
            -P ${PROJECT_SOURCE_DIR}/cmake/NebulaBuildVersion.cmake
    COMMAND sh -c "gzip -9n < debian-changelog > changelog.gz"
    DEPENDS ${NEBULA_VERSION_HEADER} ${PROJECT_SOURCE_DIR}/cmake/NebulaBuildVersion.cmake
    WORKING_DIRECTORY ${CMAKE_CURRENT_BINARY_DIR} VERBATIM)
add_custom_target(nebula_debian_changelog ALL DEPENDS ${CMAKE_CURRENT_BINARY_DIR}/changelog.gz)
add_dependencies(nebula_debian_changelog nebula_version_header)
install(FILES ${CMAKE_CURRENT_BINARY_DIR}/changelog.gz DESTINATION ${CMAKE_INSTALL_DOCDIR}
        COMPONENT tools)

# The Debian package: everything above in one .deb; its dependencies are the shared libraries
# the tools load, found by dpkg-shlibdeps, plus the -dev packages a program built against
# libnebula needs (its headers include OpenVDB's, fmt's and nlohmann-json's).
set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME nebula)
set(CPACK_PACKAGE_VERSION ${NEBULA_VERSION}) # the configure step's; at packaging time, the
# build's (NebulaBuildVersion.cmake), which the tools print
file(WRITE ${CMAKE_CURRENT_BINARY_DIR}/NebulaCPackVersion.cmake
     "set(HEADER \"${NEBULA_VERSION_HEADER}\")\n"
     "include(\"${PROJECT_SOURCE_DIR}/cmake/NebulaBuildVersion.cmake\")\n")
set(CPACK_PROJECT_CONFIG_FILE ${CMAKE_CURRENT_BINARY_DIR}/NebulaCPackVersion.cmake)
set(CPACK_PACKAGE_CONTACT "nebula developers <nebula@localhost>")
set(CPACK_RESOURCE_FILE_LICENSE ${PROJECT_SOURCE_DIR}/LICENSE) # Apache-2.0 (NEBULA_LICENSE)
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY
    "physically based rendering of reflection and emission nebulae from OpenVDB grids")
# Lines of at most 80 characters (Debian policy 5.6.13).
set(CPACK_PACKAGE_DESCRIPTION
    "Command-line tools (nebgen, nebillum, nebscatter, nebphase, nebpyramid,
nebrender, nebtone, nebimport, nebexport, nebstats, nebview, nebionize) that generate,
light, render, measure and show live nebulae from OpenVDB grids, with
multiple scattering, spectral rendering and calibrated FITS output; and
libnebula, the static library they are built on, with its CMake and
pkg-config packages.")
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT) # nebula_<version>_amd64.deb
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# bash-completion loads the completion files on demand; the -dev packages are for building
# against libnebula.
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS
    "bash-completion, libopenvdb-dev, libfmt-dev, nlohmann-json3-dev")
set(CPACK_DEBIAN_PACKAGE_SUGGESTS "python3-astropy, python3-matplotlib, openmpi-bin")
set(CPACK_STRIP_FILES ON)
include(CPack)
