// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file scene_assembly.h
/// The one seam from files to scene: the grids a tool read (io/grid_io.h) become the typed
/// scene the integrators render (render/scene.h, render/spectral.h): the density, emission
/// and tau.<star> grids as one SparseVolume, the stars (the lights) and their colours, the
/// channel dust, pyramid levels, and nebscatter's field (io/scatter_field_vdb.h, its typed
/// sources scaled to the scene's stars and emission) after checking that it was made for this
/// scene; the phase table (RenderOptions::phaseTable) is checked against the dust. render/
/// sees no OpenVDB and no GridSet: every check of a file against the scene is here.
/// nebrender, nebview and nebscatter build their scenes here (src/stages/scene_assembly.cpp
/// and spectral_scene_assembly.cpp).

#include "nebula/io/grid_io.h"
#include "nebula/physics/dust.h"
#include "nebula/render/options.h"
#include "nebula/render/scene.h"
#include "nebula/render/spectral.h"

namespace nebula {

/// Builds the scene from nebillum's output: density (opts.densityGrid), emission (optional) and
/// tau.<star> for every star in nebula:stars. Throws Error naming the file and grid on anything
/// missing or inconsistent (no stars, a tau grid missing, kappa_V of a tau grid != the dust's), or
/// if opts.phaseTable was made for another albedo, g or phase model than @p dust (unless
/// opts.phaseIgnoreDust). With opts.levels = K, also reads density.L<k> and tau.<star>.L<k>
/// for k = 1..K and throws Error if one is missing or its voxels are not 2^k times level 0's.
/// With opts.scatterField and an input holding nebscatter's field (nebula:scatter; with
/// opts.spectral.enabled the spectral field, nebula:scatter_spectral), reads it into
/// RenderScene::scatter; throws Error if it was made for other dust, stars (a summed
/// field: also their luminosity), wavelengths, star distance clamp, density or emission grid
/// or grid transform, or if a field grid is missing or not a FloatGrid on the field level's
/// transform; UsageError if it would be combined with a phase table or pyramid levels, or if
/// --emission-scale would make a radiance beyond MAX_RADIANCE.
RenderScene buildScene(const GridSet& grids, const RenderOptions& opts, const DustParams& dust);

/// Builds the spectral scene: validateSpectralOptions() first, then everything buildScene()
/// checks and reads (with opts.scatterField, the spectral field into base.scatter), plus every
/// emission grid (opts.emissionGrid and each FloatGrid with nebula:lines metadata), the
/// temperature grid (opts.spectral.temperatureGrid, optional; Error if a value is negative, NaN
/// or infinite) and the velocity grid (opts.spectral.velocityGrid, optional; Error unless a
/// Vec3fGrid of finite values), and every absorption grid (`absorption.<species>`, DESIGN
/// §7.6; Error unless a FloatGrid of finite values >= 0 with a parsable
/// `nebula:absorption-lines`). The emission grid's lines: opts.spectral.lines if given, else
/// its nebula:lines metadata, else "H-alpha:1,H-beta:0.35" (Case B Balmer ratio). UsageError
/// for an --exaggerate-velocity that makes gas move at the speed of light, or a
/// --temperature-scale that makes a voxel hotter than any star.
SpectralScene buildSpectralScene(const GridSet& grids, const RenderOptions& opts,
                                 const DustParams& dust);

/// Throws UsageError naming the file and its first absorption grid (`absorption.<species>`)
/// if @p grids has one: the RGB integrators cannot draw lines; nebrender --spectral can.
void refuseAbsorptionGrids(const GridSet& grids);

} // namespace nebula
