// SPDX-License-Identifier: Apache-2.0
#pragma once
// A small lit scene for nebview's tests (tests/unit/stages/test_view.cpp,
// tests/unit/serve/test_view_server.cpp): a uniform cube of dust and a star beside it.

#include "nebula/core/run.h"
#include "nebula/io/grid_io.h"
#include "nebula/stages/illuminate.h"
#include "nebula/stages/view.h"

#include <openvdb/openvdb.h>

#include <memory>

namespace nebula::test {

/// Voxel [pc], the cube's density n_H [cm^-3] over index [-8, 7]^3, kappa_V.
inline constexpr double VIEW_H = 0.1;
inline constexpr double VIEW_N0 = 100.0;
inline constexpr double VIEW_KAPPA = 1.5e-3;

/// The cube (world -0.8 .. 0.7 pc on each axis) with a star "s" at (0, 1.5, -0.3) pc, lit by
/// nebillum's stage.
inline std::shared_ptr<const GridSet> litCube()
{
    openvdb::initialize();
    auto g = openvdb::FloatGrid::create(0.0f);
    g->setName("density");
    g->setGridClass(openvdb::GRID_FOG_VOLUME);
    g->setTransform(openvdb::math::Transform::createLinearTransform(VIEW_H));
    auto acc = g->getAccessor();
    for (int k = -8; k < 8; ++k)
        for (int j = -8; j < 8; ++j)
            for (int i = -8; i < 8; ++i)
                acc.setValue(openvdb::Coord(i, j, k), float(VIEW_N0));
    auto set = std::make_shared<GridSet>();
    set->source = "cube";
    set->grids.push_back(g);
    Star s;
    s.name = "s";
    s.position = {0.0, 1.5, -0.3};
    s.luminosity = 100.0;
    s.temperature = 10000.0;
    set->setStars({s});
    DustParams dust;
    dust.kappa_V = VIEW_KAPPA;
    set->setDust(dust);
    IllumOptions illum;
    illum.dust = dust;
    illuminate(*set, illum, Run());
    return set;
}

/// nebview's settings for the cube: a camera on the -z axis looking at its centre.
inline ViewSettings cubeSettings(int width = 64, int height = 48)
{
    ViewSettings s;
    s.render.camera.eye = {0.0, 0.0, -5.0};
    s.render.camera.lookAt = {0.0, 0.0, 0.0};
    s.render.camera.fovDeg = 50.0; // the star (18 degrees above the axis) in view
    s.render.camera.width = width;
    s.render.camera.height = height;
    return s;
}

} // namespace nebula::test
