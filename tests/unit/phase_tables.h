// SPDX-License-Identifier: Apache-2.0
#pragma once
// A small phase table specification shared by the phase-table tests (physics and io).

#include "nebula/physics/phase_table.h"

namespace nebula::test {

/// Five t rows (1e-3 .. 10), 16 mu bins, few photons: quick, and still meets its error target.
inline PhaseTableSpec smallSpec()
{
    PhaseTableSpec s;
    s.tMin = 1e-3;
    s.tMax = 10.0;
    s.tCount = 5; // 1e-3, 1e-2, 0.1, 1, 10
    s.muBins = 16;
    s.minPhotons = 2048;
    s.maxPhotons = 65536;
    s.targetError = 0.02;
    return s;
}

} // namespace nebula::test
