// SPDX-License-Identifier: Apache-2.0
/// @file ionize.cpp
/// nebionize: the ionisation of the gas by its stars and its line emission (DESIGN §16).

#include "nebula/stages/ionize.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/units.h"
#include "nebula/io/grid_names.h"
#include "nebula/io/spectral_grids.h"
#include "nebula/io/volume_vdb.h"
#include "nebula/physics/lines.h"

#include <openvdb/tree/LeafManager.h>

#include <array>
#include <atomic>
#include <cmath>
#include <mutex>

namespace nebula {

namespace {

/// erg s^-1 cm^-3 sr^-1 -> L_sun pc^-3 sr^-1.
constexpr double CGS_TO_LSUN_PC3 = PC_CM * PC_CM * PC_CM / L_SUN_CGS;

/// The output grids, in order.
enum Output { HII, OIII_FRACTION, E_H, E_OIII, E_NII, E_SII, E_OI, OUTPUTS };

const std::array<const char*, OUTPUTS> NAMES = {
    HII_GRID,          OIII_FRACTION_GRID, EMISSION_H_GRID, EMISSION_OIII_GRID,
    EMISSION_NII_GRID, EMISSION_SII_GRID,  EMISSION_OI_GRID};

/// The emissivities of one voxel [L_sun pc^-3 sr^-1] and its fractions.
std::array<float, OUTPUTS> voxelOutputs(const VoxelIonization& v, double n, const Abundances& ab)
{
    const double T = v.te;
    std::array<float, OUTPUTS> out{};
    out[HII] = float(v.hii);
    out[OIII_FRACTION] = float(v.oiii);
    if (v.hii <= 0.0 && v.front <= 0.0) return out;
    const double k = CGS_TO_LSUN_PC3 * INV_FOUR_PI;
    const double ionised = v.ne * n; // n_e n_H of the ionised part [cm^-6]
    out[E_H] = float(k * ionised * v.hii * hBetaEmissivity(T) * (1.0 + balmerDecrement(T)));
    out[E_OIII] =
        float(k * ionised * ab.o * v.oiii * forbiddenEmissivitySum(oiiiLevels(), T, v.ne));
    // The layer at a front: half-ionised gas, n_e n_X = n_H^2 / 4 for the neutral atoms there
    // (O0) and the singly ionised ones (N+, S+).
    const double layer = 0.25 * n * n * v.front, neLayer = 0.5 * n;
    const double nPlus = std::max(0.0, v.hii - v.oiii); // N+/N follows O+/O
    const double sPlus = std::max(0.0, v.hii - v.heii); // S++ where He is ionised
    out[E_NII] = float(k * ab.n *
                       (ionised * nPlus * forbiddenEmissivitySum(niiLevels(), T, v.ne) +
                        layer * forbiddenEmissivitySum(niiLevels(), T, neLayer)));
    out[E_SII] = float(k * ab.s *
                       (ionised * sPlus * forbiddenEmissivitySum(siiLevels(), T, v.ne) +
                        layer * forbiddenEmissivitySum(siiLevels(), T, neLayer)));
    out[E_OI] = float(k * ab.o * layer * forbiddenEmissivitySum(oiLevels(), T, neLayer));
    return out;
}

/// Requires a voxel that is a cube (any rotation or mirror): the rays' solid angles are
/// index space's. Returns its edge [pc].
double cubicVoxelSize(const openvdb::FloatGrid& grid, const std::string& source)
{
    const Affine a = affineFromTransform(grid.transform());
    Vec3 col[3];
    for (int c = 0; c < 3; ++c)
        col[c] = a.applyLinear(Vec3(c == 0, c == 1, c == 2));
    const double size = col[0].length();
    for (int c = 0; c < 3; ++c) {
        const bool square = std::fabs(col[c].length() - size) <= 1e-6 * size;
        const bool orthogonal = std::fabs(col[c].dot(col[(c + 1) % 3])) <= 1e-6 * size * size;
        if (!square || !orthogonal) {
            throw Error(source + ": grid \"" + grid.getName() +
                        "\" has voxels that are not cubes (its transform scales or shears the "
                        "axes differently); nebionize needs cubic voxels: resample the grid");
        }
    }
    return size;
}

std::vector<IonizingStar> ionizingStars(const std::vector<Star>& stars, const Affine& worldToIndex)
{
    std::vector<IonizingStar> out;
    for (const auto& s : stars) {
        IonizingStar is;
        is.name = s.name;
        is.position = worldToIndex.apply(Vec3(s.position[0], s.position[1], s.position[2]));
        is.rates = ionizingRates(s.luminosity, s.temperature, s.ionizingRate, s.oiiiRate);
        is.temperature = s.temperature;
        out.push_back(is);
    }
    return out;
}

void describe(const Run& run, const std::vector<IonizingStar>& stars, const IonizeReport& report)
{
    using detail::numberText;
    for (std::size_t s = 0; s < stars.size(); ++s) {
        const auto& p = report.photons[s];
        const auto& q = report.rates[s];
        run.info("star " + stars[s].name + ": Q(H0) " + numberText(q.h) + " s^-1, above 24.6 eV " +
                 numberText(q.he) + ", above 35.1 eV " + numberText(q.oiii) + "; recombined " +
                 numberText(p.recombined / p.emitted) + ", dust " + numberText(p.dust / p.emitted) +
                 ", escaping " + numberText(p.escaped / p.emitted));
        if (p.escaped > 0.0) {
            run.info("star " + stars[s].name + " ionises the gas out to the grid's edge over " +
                     numberText(p.openSolidAngle / (4.0 * PI)) +
                     " of the sky (not an error): the escaping fraction of its ionising "
                     "photons is " +
                     numberText(p.escaped / p.emitted));
        }
    }
    double photons = 0.0;
    for (const auto& r : report.rates)
        photons += r.h;
    run.info("electron temperature: mean " + numberText(report.meanTemperature) +
             " K (weighted by n_e n_p)");
    run.info("overlap iterations: " + std::to_string(report.iterations) +
             "; recombinations in the grid / photons: " +
             numberText(report.recombinations / std::max(1e-300, photons)));
}

} // namespace

double ionizingDustCrossSection(const DustParams& dust)
{
    return 2.0 * dust.kappa_V / PC_CM;
}

IonizeReport ionize(GridSet& grids, const IonizeOptions& opts, const Run& run)
{
    auto density = grids.floatGrid(opts.densityGrid, "--density-grid");
    requireFiniteNonNegative(*density, grids.source);
    if (density->tree().activeTileCount() > 0) { // the outputs are made leaf by leaf
        auto voxels = density->deepCopy();
        voxels->tree().voxelizeActiveTiles();
        density = voxels;
    }
    const auto stars = opts.stars.empty() ? grids.stars() : opts.stars;
    if (stars.empty()) {
        throw Error(grids.source + ": no stars: the file has no " + std::string(META_STARS) +
                    " metadata; give --star or --stars");
    }
    opts.dust.validate();
    const double voxelPc = cubicVoxelSize(*density, grids.source);

    std::vector<openvdb::FloatGrid::ConstPtr> sources{density->copy()};
    if (!opts.temperatureGrid.empty()) { // the gas's electron temperature, channel 1
        const auto t = grids.floatGrid(opts.temperatureGrid, "--temperature-grid");
        requireValidTemperature(*t, grids.source);
        sources.push_back(t);
    }
    const SparseVolume n = volumeFromGrids(sources, activeBounds({sources[0]}, 1), grids.source);
    const auto ionizing = ionizingStars(stars, n.indexToWorld.inverse());
    IonizationParams params;
    // Without a fixed T_e the thermal balance sets it; 8000 K only starts each ray's march.
    params.thermalBalance = !(opts.electronTemperature > 0.0);
    params.electronTemperature = params.thermalBalance ? 8000.0 : opts.electronTemperature;
    params.abundances = opts.abundances;
    params.voxelSizeCm = voxelPc * PC_CM;
    params.raySpacing = opts.raySpacing;
    params.dustCrossSection = opts.dustAbsorbs ? ionizingDustCrossSection(opts.dust) : 0.0;
    IonizationSolver solver(n, ionizing, params);
    solver.solve(&run);

    IonizeReport report;
    report.photons = solver.photons();
    for (const auto& s : ionizing)
        report.rates.push_back(s.rates);
    report.iterations = solver.iterations();

    // Every output leaf from the density's leaves, in parallel; only leaves with a value.
    const double voxelCm3 = std::pow(params.voxelSizeCm, 3);
    openvdb::tree::LeafManager<const openvdb::FloatTree> leaves(density->tree());
    using Leaf = openvdb::FloatTree::LeafNodeType;
    std::vector<std::array<Leaf*, OUTPUTS>> made(leaves.leafCount());
    std::mutex sumMutex;
    double recombinations = 0.0, neWeight = 0.0, neSum = 0.0, teSum = 0.0;
    leaves.foreach ([&](const Leaf& leaf, std::size_t l) {
        std::array<Leaf*, OUTPUTS>& mine = made[l];
        mine.fill(nullptr);
        double rec = 0.0, w = 0.0, wne = 0.0, wte = 0.0;
        for (auto it = leaf.cbeginValueOn(); it; ++it) {
            const auto c = it.getCoord();
            const double nH = *it;
            if (!(nH > 0.0)) continue;
            const VoxelIonization v = solver.at(c.x(), c.y(), c.z());
            const auto values = voxelOutputs(v, nH, opts.abundances);
            rec += caseBRecombinationH(v.te) * v.ne * nH * v.hii * voxelCm3;
            w += v.ne * nH * v.hii;
            wne += v.ne * v.ne * nH * v.hii;
            wte += v.te * v.ne * nH * v.hii;
            for (int g = 0; g < OUTPUTS; ++g) {
                if (values[g] == 0.0f) continue;
                if (!mine[g]) mine[g] = new Leaf(leaf.origin(), 0.0f, false);
                mine[g]->setValueOn(c, values[g]);
            }
        }
        const std::lock_guard<std::mutex> lock(sumMutex);
        recombinations += rec;
        neWeight += w;
        neSum += wne;
        teSum += wte;
    });
    report.recombinations = recombinations;
    // The lines' ratios at the emission-weighted mean n_e and T_e of the ionised gas.
    const double neMean = neWeight > 0.0 ? neSum / neWeight : 100.0;
    const double T = neWeight > 0.0 ? teSum / neWeight : params.electronTemperature;
    report.meanTemperature = T;

    char decrement[32];
    std::snprintf(decrement, sizeof decrement, "%.4g", balmerDecrement(T));
    const std::array<std::string, OUTPUTS> lines = {"",
                                                    "",
                                                    std::string("H-alpha:") + decrement +
                                                        ",H-beta:1",
                                                    forbiddenLineList(oiiiLevels(), T, neMean),
                                                    forbiddenLineList(niiLevels(), T, neMean),
                                                    forbiddenLineList(siiLevels(), T, neMean),
                                                    forbiddenLineList(oiLevels(), T, neMean)};
    for (int g = 0; g < OUTPUTS; ++g) {
        auto grid = openvdb::FloatGrid::create(0.0f);
        grid->setTransform(density->transform().copy());
        for (auto& m : made)
            if (m[g]) grid->tree().addLeaf(m[g]);
        grid->setName(NAMES[g]);
        grid->setGridClass(g >= E_H ? openvdb::GRID_FOG_VOLUME : openvdb::GRID_UNKNOWN);
        grid->insertMeta("density_grid", openvdb::StringMetadata(density->getName()));
        grid->insertMeta("electron_temperature", openvdb::DoubleMetadata(T));
        if (g >= E_H) {
            grid->insertMeta(META_LINES, openvdb::StringMetadata(lines[g]));
            grid->insertMeta("units", openvdb::StringMetadata("L_sun pc^-3 sr^-1"));
        } else {
            grid->insertMeta("units", openvdb::StringMetadata(g == HII ? "H+/H" : "O++/O"));
        }
        if (opts.onlyNew && g == 0) grids.grids.clear();
        grids.replace(grid);
    }
    grids.setStars(stars);
    grids.setDust(opts.dust);
    describe(run, ionizing, report);
    return report;
}

} // namespace nebula
