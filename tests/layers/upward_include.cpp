// SPDX-License-Identifier: Apache-2.0
// Must NOT compile: a core/ unit including a render/ header. The test layer_rule_enforced
// compiles this file with nebula_core's include directories and expects the compiler to fail,
// which shows that the build itself refuses an upward include (docs/ARCHITECTURE.md).
#include "nebula/core/error.h"
#include "nebula/render/camera.h"

int main()
{
    return 0;
}
