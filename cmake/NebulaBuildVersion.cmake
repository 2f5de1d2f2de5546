# SPDX-License-Identifier: Apache-2.0
# Reads the version a build wrote into its version header (cmake/NebulaVersion.cmake; git
# describe at that build, not at the configure step) into NEBULA_BUILD_VERSION. Used twice:
#   cpack (CPACK_PROJECT_CONFIG_FILE, HEADER set by the configured copy): the
#     package's version is that of the tools it holds, also in a build directory configured
#     several commits ago;
#   cmake -DHEADER=... -DOUTPUT=... -P NebulaBuildVersion.cmake: writes Debian's changelog
#     (OUTPUT) for that version.
file(STRINGS "${HEADER}" line REGEX "^#define NEBULA_VERSION_STRING \"")
if(NOT line MATCHES "\"([^\"]+)\"")
    message(FATAL_ERROR "${HEADER}: no NEBULA_VERSION_STRING (build first)")
endif()
set(NEBULA_BUILD_VERSION "${CMAKE_MATCH_1}")
if(CPACK_GENERATOR)
    set(CPACK_PACKAGE_VERSION "${NEBULA_BUILD_VERSION}")
elseif(OUTPUT)
    string(TIMESTAMP date "%a, %d %b %Y %H:%M:%S +0000" UTC)
    file(WRITE "${OUTPUT}"
         "nebula (${NEBULA_BUILD_VERSION}) unstable; urgency=low\n\n"
         "  * Built from git describe ${NEBULA_BUILD_VERSION}; the changes are in\n"
         "    /usr/share/doc/nebula/CHANGELOG.md.\n\n"
         " -- nebula developers <nebula@localhost>  ${date}\n")
endif()
