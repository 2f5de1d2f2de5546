// SPDX-License-Identifier: Apache-2.0
#include "nebula/stages/generate.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"
#include "nebula/core/memory.h"

#include "nebula_model.h"

#include <openvdb/tools/Prune.h>
#include <openvdb/tree/LeafManager.h>

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <memory>
#include <sstream>

namespace nebula {

using detail::numberText;

namespace {

using detail::smoothstep;

/// Shapes fBm (about [-1, 1]) into a clumpy non-negative field: zero in the voids below
/// the threshold, growing as a power into the clumps.
double shape(double f, double threshold, double contrast, double exponent)
{
    const double v = contrast * (f - threshold);
    return v > 0.0 ? std::pow(v, exponent) : 0.0;
}

/// The spectral grids' shared active topology: density union emission, as voxels.
template <typename TreeT>
typename TreeT::Ptr unionTopology(const openvdb::FloatGrid& a, const openvdb::FloatGrid& b,
                                  const typename TreeT::ValueType& background)
{
    auto tree = std::make_shared<TreeT>(a.tree(), background, openvdb::TopologyCopy());
    tree->topologyUnion(b.tree());
    tree->voxelizeActiveTiles();
    return tree;
}

/// `temperature` [K] on the active voxels of density and emission (DESIGN §2).
openvdb::FloatGrid::Ptr temperatureGrid(const NebulaParams& p, const openvdb::FloatGrid& dGrid,
                                        const openvdb::FloatGrid& eGrid)
{
    auto tree = unionTopology<openvdb::FloatTree>(dGrid, eGrid, 0.0f);
    const auto& xform = dGrid.transform();
    const double rMin = 0.5 * p.size / p.res; // r clamped to half a voxel
    const auto& eTree = eGrid.tree();
    openvdb::tree::LeafManager<openvdb::FloatTree> leaves(*tree);
    leaves.foreach ([&](openvdb::FloatTree::LeafNodeType& leaf, std::size_t) {
        const auto* eLeaf = eTree.probeConstLeaf(leaf.origin());
        for (auto it = leaf.beginValueOn(); it; ++it) {
            const openvdb::Coord c = it.getCoord();
            const float e = eLeaf ? eLeaf->getValue(c) : eTree.getValue(c);
            if (p.spectral.gasTemperature > 0.0 && e > 0.0f) {
                it.setValue(float(p.spectral.gasTemperature));
                continue;
            }
            const openvdb::Vec3d x = xform.indexToWorld(c);
            const double U = radiationFieldU({x[0], x[1], x[2]}, p.stars, rMin);
            it.setValue(float(dustTemperature(U)));
        }
    });
    auto grid = openvdb::FloatGrid::create(tree);
    grid->setTransform(xform.copy());
    grid->setName("temperature");
    grid->setGridClass(openvdb::GRID_UNKNOWN);
    grid->insertMeta("units", openvdb::StringMetadata("K"));
    return grid;
}

/// `velocity` [km/s] in world axes on the active voxels of density and emission.
openvdb::Vec3fGrid::Ptr velocityGridOf(const NebulaParams& p, const openvdb::FloatGrid& dGrid,
                                       const openvdb::FloatGrid& eGrid)
{
    const MotionField field(motionParams(p), p.size);
    auto tree = unionTopology<openvdb::Vec3fTree>(dGrid, eGrid, openvdb::Vec3f(0.0f));
    const auto& xform = dGrid.transform();
    openvdb::tree::LeafManager<openvdb::Vec3fTree> leaves(*tree);
    leaves.foreach ([&](openvdb::Vec3fTree::LeafNodeType& leaf, std::size_t) {
        for (auto it = leaf.beginValueOn(); it; ++it) {
            const openvdb::Vec3d x = xform.indexToWorld(it.getCoord());
            const auto v = field({x[0], x[1], x[2]});
            it.setValue(openvdb::Vec3f(float(v[0]), float(v[1]), float(v[2])));
        }
    });
    auto grid = openvdb::Vec3fGrid::create(tree);
    grid->setTransform(xform.copy());
    grid->setName("velocity");
    grid->setGridClass(openvdb::GRID_UNKNOWN);
    grid->setVectorType(openvdb::VEC_CONTRAVARIANT_RELATIVE);
    grid->setIsInWorldSpace(true);
    grid->insertMeta("units", openvdb::StringMetadata("km/s"));
    return grid;
}

} // namespace

std::array<double, 3> motionCentre(const NebulaParams& params)
{
    if (params.motionCentre) return *params.motionCentre;
    if (!params.stars.empty()) return params.stars.front().position;
    return {0.0, 0.0, 0.0};
}

MotionParams motionParams(const NebulaParams& params)
{
    MotionParams m = params.spectral.motion;
    m.centre = motionCentre(params);
    m.radius = params.motionRadius ? *params.motionRadius : params.emissionRadius * params.size;
    m.seed = params.seed;
    return m;
}

double radiationFieldU(const std::array<double, 3>& x, const std::vector<Star>& stars, double rMin)
{
    double U = 0.0;
    for (const auto& s : stars) {
        const double dx = x[0] - s.position[0], dy = x[1] - s.position[1],
                     dz = x[2] - s.position[2];
        const double r_cm = std::max(std::sqrt(dx * dx + dy * dy + dz * dz), rMin) * PC_CM;
        // u = L / (4 pi r^2 c): the energy density of the star's unattenuated light.
        U += s.luminosity * L_SUN_CGS / (4.0 * PI * r_cm * r_cm * SPEED_OF_LIGHT_CGS * U_ISRF);
    }
    return U;
}

std::vector<Star> exampleStars()
{
    Star alpha;
    alpha.name = "alpha";
    alpha.position = {0.4, 0.3, -0.2};
    alpha.luminosity = 8000.0;
    alpha.temperature = spectralClassTemperature("B1V");
    Star beta;
    beta.name = "beta";
    beta.position = {-2.6, -1.5, 1.2};
    beta.luminosity = 60.0;
    beta.temperature = spectralClassTemperature("A0V");
    return {alpha, beta};
}

namespace {

/// Throws UsageError naming nebgen's option for any parameter out of range.
void validateParams(const NebulaParams& p)
{
    if (p.res < 2 || p.res > 2048) throw UsageError("--res must be in [2, 2048]");
    if (!(p.size > 0.0) || !std::isfinite(p.size)) throw UsageError("--size must be > 0 pc");
    if (!(p.densityPeak >= 0.0)) throw UsageError("--density must be >= 0 cm^-3");
    if (!(p.emissionPeak >= 0.0)) throw UsageError("--emission must be >= 0");
    if (p.fbm.octaves < 1 || p.fbm.octaves > 16) throw UsageError("--octaves must be in [1, 16]");
    if (!(p.cavity >= 0.0)) throw UsageError("--cavity must be >= 0 pc");
    if (!(p.contrast > 0.0)) throw UsageError("--contrast must be > 0");
    if (!(p.exponent > 0.0)) throw UsageError("--exponent must be > 0");
    p.dust.validate();
    detail::validatePresetParams(p);
    if (p.emissionShape == EmissionShape::Shell &&
        !(p.emissionRadius > 0.0 && std::isfinite(p.emissionRadius))) {
        throw UsageError("--emission-radius must be > 0 for --emission-shape shell, got " +
                         numberText(p.emissionRadius));
    }
    if (!(p.shellWidth > 0.0 && p.shellWidth <= 1.0)) {
        throw UsageError("--shell-width must be in (0, 1] (relative to the radius), got " +
                         numberText(p.shellWidth));
    }
    if (p.motionCentre) {
        for (double c : *p.motionCentre) {
            if (!std::isfinite(c)) throw UsageError("--motion-centre must be finite [pc]");
        }
    }
    if (p.lines.empty()) throw UsageError("--lines must name at least one line");
    if (p.spectral.enabled) {
        if (!(p.spectral.gasTemperature >= 0.0) || !std::isfinite(p.spectral.gasTemperature)) {
            throw UsageError("--gas-temperature must be a finite number >= 0 [K] (0: off), got " +
                             numberText(p.spectral.gasTemperature));
        }
        if (!(p.spectral.oiii >= 0.0) || !std::isfinite(p.spectral.oiii)) {
            throw UsageError("--oiii must be a finite number >= 0 (0: off), got " +
                             numberText(p.spectral.oiii));
        }
        motionParams(p).validate();
    }
}

/// Bytes of a FloatGrid (or Vec3fGrid: @p floats 3) whose every voxel is active: leaf values
/// plus their value masks.
constexpr double sparseBytesPerVoxel(double floats)
{
    return floats * sizeof(float) + 1.0 / 8.0;
}

} // namespace

namespace {

/// The procedural nebula (DESIGN §2): domain-warped fBm dust in a perturbed spherical
/// envelope with cavities around the stars, and gas emission in a sphere or shell, with an
/// inner [O III] zone.
class NebulaField final : public detail::NebulaModel
{
public:
    explicit NebulaField(const NebulaParams& p)
        : mP(p), mShell(p.emissionShape == EmissionShape::Shell), mSeed(p.seed),
          mSeedWarp(p.seed * 0x9E3779B97F4A7C15ull + 1)
    {
        // Motion centre in cube units; the shell's radius and width, the [O III] zone's extent.
        const auto centrePc = motionCentre(p);
        mCx = centrePc[0] / p.size;
        mCy = centrePc[1] / p.size;
        mCz = centrePc[2] / p.size;
        mR = p.emissionRadius;
        mWR = p.shellWidth * p.emissionRadius;
        mR0 = mShell ? mR - mWR : 0.0;
        mR1 = mShell ? mR + mWR : mR;
    }

    /// The fields at voxel (i, j, k) of a res^3 cube.
    NebulaVoxel at(int i, int j, int k, bool withOiii) const override
    {
        const NebulaParams& p = mP;
        const int n = p.res;
        // Position in cube units, [-0.5, 0.5]^3.
        const double x = detail::cubeCoordinate(i, n), y = detail::cubeCoordinate(j, n),
                     z = detail::cubeCoordinate(k, n);
        const double r = std::sqrt(x * x + y * y + z * z);
        // Domain warp: displace the lookup by a vector fBm for filaments and lanes.
        const double f = p.frequency;
        const double wx = fbm(x * f, y * f, z * f, p.fbm, mSeedWarp);
        const double wy = fbm(x * f + 31.4, y * f, z * f, p.fbm, mSeedWarp);
        const double wz = fbm(x * f, y * f + 47.2, z * f, p.fbm, mSeedWarp);
        const double qx = x + p.warp * wx, qy = y + p.warp * wy, qz = z + p.warp * wz;
        NebulaVoxel v;
        v.density = dust(x, y, z, r, wx, qx, qy, qz);
        // Distance from the motion centre [cube edges] (shell, [O III] zone).
        const double dc =
            std::sqrt((x - mCx) * (x - mCx) + (y - mCy) * (y - mCy) + (z - mCz) * (z - mCz));
        const double envEm = mShell ? 1.0 - smoothstep(0.0, mWR, std::abs(dc - mR))
                                    : 1.0 - smoothstep(0.4 * p.emissionRadius, p.emissionRadius, r);
        if (envEm > 0.0 && p.emissionPeak > 0.0) {
            const double e = fbm(qx * f * 1.5, qy * f * 1.5, qz * f * 1.5, p.fbm, mSeed + 7);
            v.emission =
                p.emissionPeak * envEm * shape(e, p.threshold - 0.1, p.contrast, p.exponent);
        }
        if (withOiii && v.emission > 0.0) {
            // Ionisation stratification: O++ in the inner part of the ionised region.
            const double s = 1.0 - smoothstep(mR0 + 0.5 * (mR1 - mR0), mR0 + 0.8 * (mR1 - mR0), dc);
            v.oiii = p.spectral.oiii * v.emission * s;
        }
        return v;
    }

    /// False only if every voxel centre of [lo, hi] (inclusive, index space) has zero
    /// density, emission and [O III] emission, exactly as at() computes them: the generator
    /// skips such a box without evaluating the noise. fBm is a weighted mean of Perlin noise,
    /// and Perlin noise is a convex blend of gradient dot products of at most 2 in magnitude,
    /// so |fBm| <= 2: the dust envelope's edge is at most min(0.5, 1.7 envelope) from the
    /// centre, where env = 0.
    bool mayHoldNebula(const openvdb::Coord& lo, const openvdb::Coord& hi) const override
    {
        const NebulaParams& p = mP;
        // Bounds of the voxel centres in cube units, [-0.5, 0.5]^3.
        const detail::CubeBox box = detail::cubeBox(lo, hi, p.res);
        const std::array<double, 3> origin{0.0, 0.0, 0.0}, centre{mCx, mCy, mCz};
        const double margin = 1e-9; // far above the rounding of r in at()
        // The dust: env = 0 where r >= edge (> 0).
        const double dustEdge = std::min(0.5, p.envelope * (1.0 + 0.35 * 2.0));
        if (!(p.envelope > 0.0) || detail::minDistance(origin, box) < dustEdge + margin)
            return true;
        if (!(p.emissionPeak > 0.0)) return false; // no emission anywhere
        if (mShell) {
            // 1 - smoothstep(0, wR, |dc - R|) = 0 where |dc - R| >= wR (> 0, validated).
            return detail::minDistance(centre, box) < mR + mWR + margin &&
                   detail::maxDistance(centre, box) > mR - mWR - margin;
        }
        // The ball: 1 - smoothstep(0.4 R, R, r) = 0 where r >= R (> 0).
        return !(mR > 0.0) || detail::minDistance(origin, box) < mR + margin;
    }

private:
    /// Dust at cube point (x, y, z), distance r from the centre, warped point q: the fBm
    /// shaped into clumps inside a soft envelope, emptied around each star.
    double dust(double x, double y, double z, double r, double wx, double qx, double qy,
                double qz) const
    {
        const NebulaParams& p = mP;
        const double f = p.frequency;
        // Soft spherical envelope, perturbed so the edge is not a sphere.
        // (capped at the cube's inscribed sphere so no face cuts the cloud).
        const double edge = std::min(0.5, p.envelope * (1.0 + 0.35 * wx));
        const double env = 1.0 - smoothstep(0.25 * edge, edge, r);
        double dens = 0.0;
        if (env > 0.0) {
            const double d = fbm(qx * f, qy * f, qz * f, p.fbm, mSeed);
            dens = p.densityPeak * env * shape(d, p.threshold, p.contrast, p.exponent);
        }
        detail::clearStarCavities(dens, {x * p.size, y * p.size, z * p.size}, p.stars, p.cavity);
        return dens;
    }

    const NebulaParams& mP;
    bool mShell;
    std::uint64_t mSeed, mSeedWarp;
    double mCx = 0, mCy = 0, mCz = 0, mR = 0, mWR = 0, mR0 = 0, mR1 = 0;
};

using FloatLeaf = openvdb::FloatTree::LeafNodeType;

/// Calls f(lo, hi, column) (inclusive voxel bounds) for each leaf of the res^3 cube that
/// NebulaField::mayHoldNebula(), in parallel over columns of leaves along x; then
/// columnDone(kb, jb) once each column of layer kb is done.
template <typename F>
void forEachSupportLeaf(const detail::NebulaModel& field, int n, F&& f,
                        const std::function<void(int kb, int jb)>& columnDone = {})
{
    const int dim = int(FloatLeaf::DIM), nb = (n + dim - 1) / dim;
    tbb::parallel_for(0, nb * nb, [&](int col) {
        const int kb = col / nb, jb = col % nb;
        for (int ib = 0; ib < nb; ++ib) {
            const openvdb::Coord lo(ib * dim, jb * dim, kb * dim);
            const openvdb::Coord hi =
                openvdb::Coord::minComponent(lo.offsetBy(dim - 1), openvdb::Coord(n - 1));
            if (field.mayHoldNebula(lo, hi)) f(lo, hi, col);
        }
        if (columnDone) columnDone(kb, jb);
    });
}

/// The leaves generateNebula() keeps from one column of leaves, per grid.
struct LeafColumn
{
    std::vector<std::unique_ptr<FloatLeaf>> density, emission, oiii;
};

/// A fog-volume FloatGrid of the leaves @p field of every column (their non-zero voxels
/// active), pruned; the leaves move into it.
openvdb::FloatGrid::Ptr fogGrid(std::vector<LeafColumn>& columns,
                                std::vector<std::unique_ptr<FloatLeaf>> LeafColumn::*field,
                                openvdb::math::Transform::Ptr xform, const std::string& name,
                                const std::string& units)
{
    auto grid = openvdb::FloatGrid::create(0.0f);
    for (auto& column : columns) {
        for (auto& leaf : column.*field)
            grid->tree().addLeaf(leaf.release());
        (column.*field).clear();
    }
    openvdb::tools::prune(grid->tree());
    grid->setTransform(xform);
    grid->setName(name);
    grid->setGridClass(openvdb::GRID_FOG_VOLUME);
    grid->insertMeta("units", openvdb::StringMetadata(units));
    return grid;
}

/// The model of @p p's preset (without its lattice: only the support).
std::unique_ptr<detail::NebulaModel> makeModel(const NebulaParams& p, bool withLattice)
{
    if (p.preset == NebulaPreset::Fbm) return std::make_unique<NebulaField>(p);
    return detail::makePresetModel(p, withLattice);
}

} // namespace

double generateBytes(const NebulaParams& p)
{
    validateParams(p);
    const bool oiiiOn = p.spectral.enabled && p.spectral.oiii > 0.0;
    const double fields = oiiiOn ? 3.0 : 2.0; // density, emission (, emission.oiii)
    // At worst every voxel of the leaves the fields' support touches is active, in each grid:
    // fog grids built leaf by leaf (no dense arrays), and the spectral temperature and
    // velocity grids on the same voxels.
    double perVoxel = fields * sparseBytesPerVoxel(1.0);
    if (p.spectral.enabled) perVoxel += sparseBytesPerVoxel(1.0) + sparseBytesPerVoxel(3.0);
    std::atomic<std::uint64_t> voxels{0};
    const auto model = makeModel(p, false);
    forEachSupportLeaf(*model, p.res, [&](const openvdb::Coord& lo, const openvdb::Coord& hi, int) {
        voxels += std::uint64_t(hi.x() - lo.x() + 1) * std::uint64_t(hi.y() - lo.y() + 1) *
                  std::uint64_t(hi.z() - lo.z() + 1);
    });
    return double(voxels.load()) * perVoxel + model->heldBytes();
}

NebulaVoxel nebulaVoxel(const NebulaParams& params, int i, int j, int k)
{
    validateParams(params);
    const bool oiiiOn = params.spectral.enabled && params.spectral.oiii > 0.0;
    return makeModel(params, true)->at(i, j, k, oiiiOn);
}

GridSet generateNebula(const NebulaParams& p, const std::function<void(std::size_t)>& progress)
{
    validateParams(p);
    const bool oiiiOn = p.spectral.enabled && p.spectral.oiii > 0.0;
    requireMemory(generateBytes(p), "--res " + std::to_string(p.res) + ": generating the grids");
    const int n = p.res;
    const double voxel = p.size / n;
    // Voxel centres at integer index coordinates, the cube centred on the world origin.
    auto xform = openvdb::math::Transform::createLinearTransform(voxel);
    xform->postTranslate(openvdb::Vec3d(-0.5 * (n - 1) * voxel));

    // Leaf by leaf (8^3 voxels), in parallel over columns of leaves along x; leaves outside
    // the fields' support are never evaluated, and leaves of zeros never stored.
    const auto model = makeModel(p, true);
    const detail::NebulaModel& field = *model;
    const int dim = int(FloatLeaf::DIM), nb = (n + dim - 1) / dim;
    std::vector<LeafColumn> columns(std::size_t(nb) * std::size_t(nb));
    std::vector<std::atomic<int>> layerDone(static_cast<std::size_t>(nb));
    const auto fill = [&](const openvdb::Coord& lo, const openvdb::Coord& hi, int col) {
        auto d = std::make_unique<FloatLeaf>(lo, 0.0f, false);
        auto e = std::make_unique<FloatLeaf>(lo, 0.0f, false);
        std::unique_ptr<FloatLeaf> o;
        if (oiiiOn) o = std::make_unique<FloatLeaf>(lo, 0.0f, false);
        bool anyD = false, anyE = false, anyO = false;
        // Zero (and -0) voxels stay inactive, as in a fog volume.
        const auto keep = [](FloatLeaf& leaf, const openvdb::Coord& c, double value, bool& any) {
            if (const float x = float(value); x != 0.0f) {
                leaf.setValueOn(c, x);
                any = true;
            }
        };
        for (int k = lo.z(); k <= hi.z(); ++k) {
            for (int j = lo.y(); j <= hi.y(); ++j) {
                for (int i = lo.x(); i <= hi.x(); ++i) {
                    const openvdb::Coord c(i, j, k);
                    const NebulaVoxel v = field.at(i, j, k, oiiiOn);
                    keep(*d, c, v.density, anyD);
                    keep(*e, c, v.emission, anyE);
                    if (o && v.emission > 0.0) keep(*o, c, v.oiii, anyO);
                }
            }
        }
        LeafColumn& out = columns[std::size_t(col)];
        if (anyD) out.density.push_back(std::move(d));
        if (anyE) out.emission.push_back(std::move(e));
        if (anyO) out.oiii.push_back(std::move(o));
    };
    forEachSupportLeaf(field, n, fill, [&](int kb, int) {
        if (++layerDone[std::size_t(kb)] == nb && progress) {
            progress(std::size_t(std::min(dim, n - kb * dim))); // z-slices done
        }
    });

    const std::string emissionUnits = "emission [L_sun pc^-3 sr^-1]";
    auto dGrid = fogGrid(columns, &LeafColumn::density, xform, "density", "n_H [cm^-3]");
    auto eGrid = fogGrid(columns, &LeafColumn::emission, xform->copy(), "emission", emissionUnits);
    eGrid->insertMeta(META_LINES, openvdb::StringMetadata(lineListToString(p.lines)));
    GridSet set;
    set.source = "nebgen";
    set.grids = {dGrid, eGrid};
    if (oiiiOn) {
        auto oGrid =
            fogGrid(columns, &LeafColumn::oiii, xform->copy(), "emission.oiii", emissionUnits);
        oGrid->insertMeta(META_LINES, openvdb::StringMetadata(lineListToString(
                                          parseLineList(OIII_EMISSION_LINES, "[O III] lines"))));
        set.grids.push_back(oGrid);
    }
    if (p.spectral.enabled) {
        set.grids.push_back(temperatureGrid(p, *dGrid, *eGrid));
        set.grids.push_back(velocityGridOf(p, *dGrid, *eGrid));
    }
    set.setStars(p.stars);
    set.setDust(p.dust);
    return set;
}

} // namespace nebula
