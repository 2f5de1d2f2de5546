// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file version.h
/// NEBULA_VERSION_STRING: this build's version, "0.1.0" at the tag v0.1.0 and
/// "0.1.0+3.g1a2b3c4" three commits later (git describe; "+dirty" with uncommitted changes),
/// written at build time by cmake/NebulaVersion.cmake. `--version`, the grids' history and
/// the images' metadata carry it.

#include "nebula_version.h"
