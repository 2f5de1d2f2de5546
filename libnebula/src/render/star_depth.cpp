/// @file star_depth.cpp
/// Short characteristics through cells where a star's optical depth bends; see star_depth.h.

#include "nebula/render/star_depth.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

namespace nebula {

namespace {

constexpr int B = SparseVolume::BRICK;

/// The bricks of @p f that hold a lattice point within one voxel of a stored brick: the
/// stored bricks and their 26 neighbours (as brick slots). Only there can a point be near
/// dust.
std::vector<std::size_t> bricksNearStored(const SparseVolume& f)
{
    const auto& lo = f.lo();
    const auto& d = f.dims();
    const std::size_t bricks = f.voxelCount() / SparseVolume::BRICK_VOXELS;
    std::vector<std::uint8_t> keep(bricks, 0);
    tbb::parallel_for(std::size_t(0), bricks, [&](std::size_t b) {
        const auto p0 = f.point(b * SparseVolume::BRICK_VOXELS);
        for (int n = 0; n < 27 && !keep[b]; ++n) {
            std::array<int, 3> q{p0[0] + (n % 3 - 1) * B, p0[1] + (n / 3 % 3 - 1) * B,
                                 p0[2] + (n / 9 - 1) * B};
            bool on = true;
            for (int a = 0; a < 3; ++a) {
                on = on && q[a] + B - 1 >= lo[a] && q[a] <= lo[a] + d[a] - 1;
                q[a] = std::max(q[a], lo[a]); // a lattice point of that brick
            }
            keep[b] = on && f.stored(f.index(q[0], q[1], q[2]));
        }
    });
    std::vector<std::size_t> out;
    for (std::size_t b = 0; b < bricks; ++b)
        if (keep[b]) out.push_back(b);
    return out;
}

void setBit(std::vector<std::uint64_t>& bits, std::size_t v)
{
    bits[v >> 6] |= std::uint64_t(1) << (v & 63);
}

} // namespace

StarDepth::StarDepth(const RenderScene& scene)
    : mScene(scene), mColumn(scene.fields), mLo(scene.fields.lo()), mDims(scene.fields.dims()),
      mKappa(scene.dust.kappa_V)
{
    const SparseVolume& f = scene.fields;
    const std::size_t words = (f.voxelCount() + 63) / 64;
    const std::array<int, 3> hi{mLo[0] + mDims[0] - 1, mLo[1] + mDims[1] - 1,
                                mLo[2] + mDims[2] - 1};
    const auto onLattice = [&](int i, int j, int k) { return f.contains(i, j, k); };
    // Every pass below visits the bricks near stored ones in parallel; each writes only its
    // own brick's bits (8 words), so no word is shared between threads.
    const std::vector<std::size_t> todo = bricksNearStored(f);
    const auto forBricks = [&](const auto& body) {
        tbb::parallel_for(tbb::blocked_range<std::size_t>(0, todo.size(), 16),
                          [&](const tbb::blocked_range<std::size_t>& r) {
                              for (std::size_t t = r.begin(); t != r.end(); ++t)
                                  body(f.point(todo[t] * SparseVolume::BRICK_VOXELS));
                          });
    };
    // The lattice points (i, j, k) of the brick from @p p0, in order.
    const auto forPoints = [&](const std::array<int, 3>& p0, const auto& body) {
        for (int k = std::max(p0[2], mLo[2]); k <= std::min(p0[2] + B - 1, hi[2]); ++k)
            for (int j = std::max(p0[1], mLo[1]); j <= std::min(p0[1] + B - 1, hi[1]); ++j)
                for (int i = std::max(p0[0], mLo[0]); i <= std::min(p0[0] + B - 1, hi[0]); ++i)
                    body(i, j, k);
    };
    // Lattice points within one voxel of dust (where nebillum wrote tau): the dust dilated by
    // one in each of x, y and z (the 27-point neighbourhood), on a brick and its halo.
    std::vector<std::uint64_t> near(words, 0);
    forBricks([&](const std::array<int, 3>& p0) {
        constexpr int H = B + 2; // the brick and one point either side
        std::uint8_t a[H][H][H], b[H][H][H];
        for (int z = 0; z < H; ++z)
            for (int y = 0; y < H; ++y)
                for (int x = 0; x < H; ++x) {
                    const int i = p0[0] + x - 1, j = p0[1] + y - 1, k = p0[2] + z - 1;
                    a[z][y][x] = onLattice(i, j, k) && f.voxel(f.index(i, j, k))[0] > 0.0f;
                }
        for (int z = 0; z < H; ++z)
            for (int y = 0; y < H; ++y)
                for (int x = 1; x + 1 < H; ++x)
                    b[z][y][x] = a[z][y][x - 1] | a[z][y][x] | a[z][y][x + 1];
        for (int z = 0; z < H; ++z)
            for (int y = 1; y + 1 < H; ++y)
                for (int x = 1; x + 1 < H; ++x)
                    a[z][y][x] = b[z][y - 1][x] | b[z][y][x] | b[z][y + 1][x];
        forPoints(p0, [&](int i, int j, int k) {
            const int x = i - p0[0] + 1, y = j - p0[1] + 1, z = k - p0[2] + 1;
            if (a[z - 1][y][x] | a[z][y][x] | a[z + 1][y][x]) setBit(near, f.index(i, j, k));
        });
    });
    const auto isNear = [&](int i, int j, int k) {
        return onLattice(i, j, k) && bit(near, f.index(i, j, k));
    };
    // A bit per lattice cell (at its lower corner's index): whether all (@p all) or any of its
    // 8 corners are set in @p points. Cells on the lattice's upper faces have no 8 corners.
    const auto cornerCells = [&](const auto& point, bool all) {
        std::vector<std::uint64_t> cells(words, 0);
        forBricks([&](const std::array<int, 3>& p0) {
            forPoints(p0, [&](int i, int j, int k) {
                if (i == hi[0] || j == hi[1] || k == hi[2]) return;
                bool result = all;
                for (int c = 0; c < 8 && result == all; ++c)
                    result = point(i + (c & 1), j + (c >> 1 & 1), k + (c >> 2));
                if (result) setBit(cells, f.index(i, j, k));
            });
        });
        return cells;
    };
    mValid = cornerCells(isNear, true);
    mAny.assign(words, 0);
    for (std::size_t s = 0; s < scene.stars.size(); ++s) {
        // Per lattice point: whether tau's second difference along an axis reaches CURVED.
        const int c = 2 + int(s);
        const auto tau = [&](int i, int j, int k) { return double(f.voxel(f.index(i, j, k))[c]); };
        std::vector<std::uint64_t> bends(words, 0);
        forBricks([&](const std::array<int, 3>& p0) {
            forPoints(p0, [&](int i, int j, int k) {
                // Interior points only, and where the tau grid holds values.
                if (i == mLo[0] || j == mLo[1] || k == mLo[2] || i == hi[0] || j == hi[1] ||
                    k == hi[2] || !isNear(i, j, k)) {
                    return;
                }
                // Along each axis whose three points hold tau (beyond the active band the
                // grid reads 0, which is no bend of the true tau).
                const double t = 2.0 * tau(i, j, k);
                bool b = false;
                for (int a = 0; a < 3 && !b; ++a) {
                    const int di = a == 0, dj = a == 1, dk = a == 2;
                    b = isNear(i - di, j - dj, k - dk) && isNear(i + di, j + dj, k + dk) &&
                        std::abs(tau(i - di, j - dj, k - dk) - t + tau(i + di, j + dj, k + dk)) >=
                            CURVED;
                }
                if (b) setBit(bends, f.index(i, j, k));
            });
        });
        // A cell is curved if one of its corners is.
        auto bits = cornerCells(
            [&](int i, int j, int k) { return onLattice(i, j, k) && bit(bends, f.index(i, j, k)); },
            false);
        for (std::size_t w = 0; w < bits.size(); ++w)
            mAny[w] |= bits[w];
        mCurved.push_back(std::move(bits));
    }
    const Affine w2i = f.indexToWorld.inverse();
    for (const auto& s : scene.stars)
        mStarI.push_back(w2i.apply(Vec3(s.position[0], s.position[1], s.position[2])));
}

double StarDepth::march(std::size_t s, const Vec3& pI) const
{
    const Vec3 toStar = mStarI[s] - pI;
    const double dist = toStar.length(); // [voxels, index space]
    if (!(dist > 0.0)) return 0.0;
    const Vec3 u = toStar * (1.0 / dist);
    double tau = 0.0, walked = 0.0;
    Vec3 p = pI;
    for (int step = 0;; ++step) {
        const double len = std::min(1.0, dist - walked);
        const Vec3 q = p + u * len;
        tau += mKappa * mColumn(p, q);
        walked += len;
        p = q;
        if (walked >= dist) return tau; // reached the star
        const std::size_t c = cellOf(p);
        if (c == NONE) return tau;     // left the grid: no dust from here to the star
        if (!bit(mValid, c)) continue; // no tau here: cross the gap
        if (tau > TAU_STOP || step + 1 >= MAX_STEPS || !bit(mCurved[s], c)) break;
    }
    // The rest from the tau grid at p.
    float rest = 0.0f;
    mScene.fields.sampleChannels(p, 2 + int(s), 1, &rest);
    return tau + std::max(0.0, double(rest));
}

double StarDepth::curvedFraction(std::size_t s) const
{
    std::size_t n = 0;
    for (const auto w : mCurved[s])
        n += std::size_t(__builtin_popcountll(w));
    const std::size_t cells =
        std::size_t(mDims[0] - 1) * std::size_t(mDims[1] - 1) * std::size_t(mDims[2] - 1);
    return cells > 0 ? double(n) / double(cells) : 0.0;
}

} // namespace nebula
