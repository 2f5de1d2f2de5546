# SPDX-License-Identifier: Apache-2.0
# The version of this source tree: `git describe --tags --match v[0-9]*` when it is a git
# checkout with a version tag (v0.1.0 -> 0.1.0; 3 commits later, 0.1.0+3.g1a2b3c4; with
# uncommitted changes, +dirty), else FALLBACK (project(VERSION)). Run as a script at build time
# (cmake -DSOURCE_DIR=... -DOUTPUT=... -DFALLBACK=... -P NebulaVersion.cmake) it writes OUTPUT,
# a header defining NEBULA_VERSION_STRING, only when its text changes, so that a new commit
# recompiles the few files that print the version and nothing else. Included, it sets
# NEBULA_VERSION (the configure step's value, for the package's name).
function(nebula_version source_dir fallback out_var)
    set(version "${fallback}")
    find_package(Git QUIET)
    if(GIT_FOUND AND EXISTS "${source_dir}/.git")
        execute_process(
            COMMAND "${GIT_EXECUTABLE}" -C "${source_dir}" describe --tags --match "v[0-9]*"
                    --dirty
            OUTPUT_VARIABLE describe
            RESULT_VARIABLE result
            ERROR_QUIET OUTPUT_STRIP_TRAILING_WHITESPACE)
        if(result EQUAL 0 AND describe MATCHES
           "^v([0-9]+\\.[0-9]+\\.[0-9]+)(-([0-9]+)-g([0-9a-f]+))?(-dirty)?$")
            set(version "${CMAKE_MATCH_1}")
            set(extra "")
            if(CMAKE_MATCH_3)
                set(extra "${CMAKE_MATCH_3}.g${CMAKE_MATCH_4}")
            endif()
            if(CMAKE_MATCH_5)
                if(extra)
                    string(APPEND extra ".dirty")
                else()
                    set(extra "dirty")
                endif()
            endif()
            if(extra)
                string(APPEND version "+${extra}")
            endif()
        endif()
    endif()
    set(${out_var} "${version}" PARENT_SCOPE)
endfunction()

if(CMAKE_SCRIPT_MODE_FILE)
    cmake_minimum_required(VERSION 3.18) # this script's policies
    nebula_version("${SOURCE_DIR}" "${FALLBACK}" version)
    file(CONFIGURE OUTPUT "${OUTPUT}" @ONLY CONTENT "\
// Generated at build time by cmake/NebulaVersion.cmake (git describe). Do not edit.
#pragma once
#define NEBULA_VERSION_STRING \"@version@\"
")
endif()
