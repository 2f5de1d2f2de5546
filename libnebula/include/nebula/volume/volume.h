// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file volume.h
/// Compact volumes for the hot loops (DESIGN §9, STYLE "Determinism and speed"): sparse
/// bricks of float channels over the active bounding box, several channels interleaved per
/// voxel, with trilinear sampling in index space and the grid's affine index-to-world map.
/// No OpenVDB here: hot code includes this header only (volume_vdb.h converts).

#include "nebula/core/memory.h"

#include <array>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace nebula {

/// A small 3-vector of doubles.
struct Vec3
{
    double x = 0, y = 0, z = 0;
    constexpr Vec3() = default;
    constexpr Vec3(double x_, double y_, double z_) : x(x_), y(y_), z(z_) {}
    double operator[](int i) const { return i == 0 ? x : i == 1 ? y : z; }
    double& operator[](int i) { return i == 0 ? x : i == 1 ? y : z; }
    Vec3 operator+(const Vec3& o) const { return {x + o.x, y + o.y, z + o.z}; }
    Vec3 operator-(const Vec3& o) const { return {x - o.x, y - o.y, z - o.z}; }
    Vec3 operator*(double s) const { return {x * s, y * s, z * s}; }
    Vec3 operator-() const { return {-x, -y, -z}; }
    double dot(const Vec3& o) const { return x * o.x + y * o.y + z * o.z; }
    Vec3 cross(const Vec3& o) const
    {
        return {y * o.z - z * o.y, z * o.x - x * o.z, x * o.y - y * o.x};
    }
    double length() const { return std::sqrt(dot(*this)); }
    Vec3 normalized() const { return *this * (1.0 / length()); }
};

/// An affine map x' = M x + t (e.g. index space -> world space).
struct Affine
{
    std::array<double, 9> m{1, 0, 0, 0, 1, 0, 0, 0, 1}; ///< row-major 3x3 linear part
    Vec3 t;

    Vec3 applyLinear(const Vec3& v) const
    {
        return {m[0] * v.x + m[1] * v.y + m[2] * v.z, m[3] * v.x + m[4] * v.y + m[5] * v.z,
                m[6] * v.x + m[7] * v.y + m[8] * v.z};
    }
    Vec3 apply(const Vec3& p) const { return applyLinear(p) + t; }
    /// The inverse map; the linear part must be invertible.
    Affine inverse() const;
};

/// Several float channels on the integer lattice [lo, lo + dims - 1] (voxel centres at
/// integer index coordinates, as in OpenVDB), zero outside, stored sparsely: in bricks of
/// BRICK^3 voxels aligned, as OpenVDB's leaves are, to multiples of BRICK in index space. Only
/// bricks that were written hold memory (a brick never written reads as zeros), so a volume's
/// memory follows its grids' active leaves, not their bounding box. Channel values of one voxel
/// are adjacent in memory, so one trilinear lookup fetches every channel.
///
/// A voxel index (index()) names a voxel in brick-major order: the brick's slot in the lattice
/// of bricks times BRICK_VOXELS, plus the voxel's place in its brick. Indices run from 0 to
/// voxelCount() - 1; the bricks on the lattice's upper faces have indices for points beyond
/// dims, which read zero unless written. Arrays indexed like the volume (per-voxel flags,
/// tallies) have voxelCount() entries.
class SparseVolume
{
public:
    static constexpr int BRICK_LOG2 = 3;
    static constexpr int BRICK = 1 << BRICK_LOG2; ///< voxels along a brick's edge
    static constexpr std::size_t BRICK_VOXELS = std::size_t(1) << (3 * BRICK_LOG2);

    SparseVolume() = default;
    /// An all-zero volume: no brick is stored. Throws Error if the lattice is empty or its
    /// brick table would not fit (more than 2^32 - 2 bricks).
    SparseVolume(std::array<int, 3> lo, std::array<int, 3> dims, int channels);
    SparseVolume(const SparseVolume& o);
    SparseVolume(SparseVolume&& o) noexcept;
    SparseVolume& operator=(const SparseVolume& o);
    SparseVolume& operator=(SparseVolume&& o) noexcept;
    ~SparseVolume();

    const std::array<int, 3>& lo() const { return mLo; }
    const std::array<int, 3>& dims() const { return mDims; }
    int channels() const { return mChannels; }
    /// The number of voxel indices: BRICK_VOXELS times the bricks of the lattice.
    std::size_t voxelCount() const { return mSlots.size() << (3 * BRICK_LOG2); }

    /// Voxel index of lattice point (i, j, k) (absolute index coordinates, on the lattice).
    std::size_t index(int i, int j, int k) const
    {
        const int x = i - mOrigin[0], y = j - mOrigin[1], z = k - mOrigin[2];
        constexpr int M = BRICK - 1, L = BRICK_LOG2;
        const std::size_t slot =
            (std::size_t(z >> L) * std::size_t(mBricks[1]) + std::size_t(y >> L)) *
                std::size_t(mBricks[0]) +
            std::size_t(x >> L);
        return (slot << (3 * L)) | std::size_t(((z & M) << (2 * L)) | ((y & M) << L) | (x & M));
    }
    /// The lattice point of voxel index @p idx (the inverse of index()).
    std::array<int, 3> point(std::size_t idx) const;
    bool contains(int i, int j, int k) const
    {
        return unsigned(i - mLo[0]) < unsigned(mDims[0]) &&
               unsigned(j - mLo[1]) < unsigned(mDims[1]) &&
               unsigned(k - mLo[2]) < unsigned(mDims[2]);
    }
    /// The channels of voxel @p idx (zeros if its brick is not stored).
    const float* voxel(std::size_t idx) const
    {
        return brickData(mSlots[idx >> (3 * BRICK_LOG2)]) +
               (idx & (BRICK_VOXELS - 1)) * std::size_t(mChannels);
    }
    /// The channels of voxel @p idx, to write: stores its brick (zeros) first if needed. Safe
    /// to call from several threads at once, for different voxels.
    float* writable(std::size_t idx)
    {
        return brickData(storeBrick(idx >> (3 * BRICK_LOG2))) +
               (idx & (BRICK_VOXELS - 1)) * std::size_t(mChannels);
    }
    /// Whether the brick of voxel @p idx is stored (if not, the voxel is zero).
    bool stored(std::size_t idx) const { return mSlots[idx >> (3 * BRICK_LOG2)] != 0; }
    /// Bricks stored, and the memory they and the brick table take [bytes].
    std::size_t storedBricks() const { return mUsed - 1; }
    std::size_t storedBytes() const
    {
        return storedBricks() * brickFloats() * sizeof(float) +
               mSlots.size() * sizeof(std::uint32_t);
    }
    /// Calls @p f(first) for each stored brick, in index order, with its first voxel index
    /// (its voxels are first .. first + BRICK_VOXELS - 1); the other bricks are all zero.
    template <typename F> void forEachStoredBrick(const F& f) const
    {
        for (std::size_t s = 0; s < mSlots.size(); ++s)
            if (mSlots[s]) f(s * BRICK_VOXELS);
    }
    /// Every voxel zero again; the stored bricks are kept (zeroed).
    void setZero();

    /// Every channel at half the resolution (a level of detail): voxel I of the result is the
    /// mean of this volume's 8 voxels 2I .. 2I + 1 (zeros off the lattice), so sums over
    /// voxels times voxel volume are kept; its lattice has a zero border round those voxels,
    /// so the trilinear field keeps them too; its index-to-world map puts its voxel centre at
    /// the centre of those 8 (this index 2I + 0.5). Only bricks that hold data are stored.
    /// Channels from @p firstDepth on (if >= 0) are optical depths tau, averaged instead as
    /// transmittance weighted by channel @p weight (a density n): -ln(mean n e^-tau / mean n),
    /// which keeps the mean of n e^-tau (the light a star gives the dust); the plain mean
    /// where the 8 weights are 0.
    SparseVolume halfResolution(int firstDepth = -1, int weight = 0) const;
    /// Channel @p c alone as a one-channel volume on the same lattice and transform.
    SparseVolume channel(int c) const;

    /// The channel values of the 8 corners of the lattice cell whose lower corner is (i, j, k)
    /// (on the lattice with (i + 1, j + 1, k + 1)): @p q[c] for corner (i + (c & 1),
    /// j + (c >> 1 & 1), k + (c >> 2)). One brick lookup when the cell lies in one brick.
    void cellCorners(int i, int j, int k, const float* q[8]) const
    {
        cellCorners(i, j, k, index(i, j, k), q);
    }
    /// cellCorners() where the caller has the voxel index @p idx of (i, j, k) already.
    void cellCorners(int i, int j, int k, std::size_t idx, const float* q[8]) const
    {
        const int x = i - mOrigin[0], y = j - mOrigin[1], z = k - mOrigin[2];
        constexpr int M = BRICK - 1;
        if ((x & M) != M && (y & M) != M && (z & M) != M) {
            const std::size_t sx = std::size_t(mChannels), sy = sx * BRICK, sz = sy * BRICK;
            const float* b = voxel(idx);
            q[0] = b;
            q[1] = b + sx;
            q[2] = b + sy;
            q[3] = b + sy + sx;
            q[4] = b + sz;
            q[5] = b + sz + sx;
            q[6] = b + sz + sy;
            q[7] = b + sz + sy + sx;
            return;
        }
        // Across bricks: each axis's two bricks and places in them, then one lookup a corner.
        constexpr int L = BRICK_LOG2;
        const std::size_t bx[2] = {std::size_t(x >> L), std::size_t((x + 1) >> L)};
        const std::size_t by[2] = {std::size_t(y >> L), std::size_t((y + 1) >> L)};
        const std::size_t bz[2] = {std::size_t(z >> L), std::size_t((z + 1) >> L)};
        const int ox[2] = {x & M, (x + 1) & M}, oy[2] = {y & M, (y + 1) & M},
                  oz[2] = {z & M, (z + 1) & M};
        const std::size_t nx = std::size_t(mBricks[0]), ny = std::size_t(mBricks[1]);
        for (int c = 0; c < 8; ++c) {
            const int a = c & 1, b = c >> 1 & 1, e = c >> 2;
            const std::uint32_t id = mSlots[(bz[e] * ny + by[b]) * nx + bx[a]];
            q[c] = brickData(id) +
                   std::size_t((oz[e] << (2 * L)) | (oy[b] << L) | ox[a]) * std::size_t(mChannels);
        }
    }

    /// Trilinear interpolation of every channel at index-space point @p p into @p out
    /// (channels() floats); zero outside the lattice, so keep a zero border if the field
    /// should fall to zero smoothly.
    void sample(const Vec3& p, float* out) const { sampleChannels(p, 0, mChannels, out); }

    /// The lattice cell trilinear interpolation at index-space point @p p reads: its lower
    /// corner @p ijk and @p p's position in it, @p frac in [0, 1)^3. False (outputs unset)
    /// where that cell's 8 corners are not all on the lattice: sample() is zero there.
    bool cellAt(const Vec3& p, int ijk[3], double frac[3]) const
    {
        const double fx = std::floor(p.x), fy = std::floor(p.y), fz = std::floor(p.z);
        const int i = int(fx), j = int(fy), k = int(fz);
        if (!(fx >= mLo[0] && fy >= mLo[1] && fz >= mLo[2] && i + 1 < mLo[0] + mDims[0] &&
              j + 1 < mLo[1] + mDims[1] && k + 1 < mLo[2] + mDims[2]))
            return false;
        ijk[0] = i;
        ijk[1] = j;
        ijk[2] = k;
        frac[0] = p.x - fx;
        frac[1] = p.y - fy;
        frac[2] = p.z - fz;
        return true;
    }

    /// Trilinear interpolation of channels [@p first, @p first + @p count) only (see sample()).
    void sampleChannels(const Vec3& p, int first, int count, float* out) const
    {
        int ijk[3];
        double frac[3];
        if (!cellAt(p, ijk, frac)) {
            for (int c = 0; c < count; ++c)
                out[c] = 0.0f;
            return;
        }
        const float u = float(frac[0]), v = float(frac[1]), w = float(frac[2]);
        const float* q[8];
        cellCorners(ijk[0], ijk[1], ijk[2], q);
        for (int c = first; c < first + count; ++c) {
            const float c00 = q[0][c] + u * (q[1][c] - q[0][c]);
            const float c10 = q[2][c] + u * (q[3][c] - q[2][c]);
            const float c01 = q[4][c] + u * (q[5][c] - q[4][c]);
            const float c11 = q[6][c] + u * (q[7][c] - q[6][c]);
            const float c0 = c00 + v * (c10 - c00);
            const float c1 = c01 + v * (c11 - c01);
            out[c - first] = c0 + w * (c1 - c0);
        }
    }

    /// Channel 0 at @p p (see sample()).
    float sample0(const Vec3& p) const
    {
        float v;
        sampleChannels(p, 0, 1, &v);
        return v;
    }

    Affine indexToWorld; ///< the source grid's affine map from index to world [pc]

    /// The world position [pc] of the lattice's corner @p c (0-7): bit 0 the upper x end of
    /// [lo, lo + dims - 1], bit 1 y, bit 2 z.
    Vec3 cornerWorld(int c) const
    {
        return indexToWorld.apply(Vec3(mLo[0] + (c & 1) * (mDims[0] - 1),
                                       mLo[1] + (c >> 1 & 1) * (mDims[1] - 1),
                                       mLo[2] + (c >> 2) * (mDims[2] - 1)));
    }

private:
    std::size_t brickFloats() const { return BRICK_VOXELS * std::size_t(mChannels); }
    const float* brickData(std::uint32_t id) const
    {
        return mBase + std::size_t(id) * brickFloats();
    }
    float* brickData(std::uint32_t id) { return mBase + std::size_t(id) * brickFloats(); }
    /// The id of brick @p slot's storage, storing it first if needed (thread-safe).
    std::uint32_t storeBrick(std::size_t slot);
    void release() noexcept;

    std::array<int, 3> mLo{0, 0, 0};
    std::array<int, 3> mDims{0, 0, 0};
    std::array<int, 3> mOrigin{0, 0, 0}; ///< the lowest brick's first point (multiples of BRICK)
    std::array<int, 3> mBricks{0, 0, 0}; ///< the lattice of bricks
    int mChannels = 0;
    /// Per brick slot: its storage's id, 0 (the zero brick, never written) if not stored.
    std::vector<std::uint32_t> mSlots;
    /// The bricks, one after another (id 0: zeros), in reserved address space that holds
    /// memory only where written (core/memory.h reserveAddressSpace()).
    float* mBase = nullptr;
    std::size_t mReserved = 0; ///< bytes reserved at mBase
    std::uint32_t mUsed = 1;   ///< bricks handed out, the zero brick included (atomic)
};

/// A bit per voxel index of a SparseVolume: flags per lattice point, or per lattice cell at
/// its lower corner's index. 64 bits to a word, so a brick's bits are words of its own:
/// threads that each write their own bricks share no word.
class VoxelBits
{
public:
    VoxelBits() = default;
    /// Every bit of @p v's voxel indices set to @p value.
    VoxelBits(const SparseVolume& v, bool value)
        : mWords((v.voxelCount() + 63) / 64, value ? ~std::uint64_t(0) : 0)
    {}
    bool operator[](std::size_t i) const { return (mWords[i >> 6] >> (i & 63)) & 1u; }
    void set(std::size_t i) { mWords[i >> 6] |= std::uint64_t(1) << (i & 63); }
    void clear(std::size_t i) { mWords[i >> 6] &= ~(std::uint64_t(1) << (i & 63)); }
    /// Bits 64 w .. 64 w + 63 at once (bit b of @p bits is bit 64 w + b).
    void setWord(std::size_t w, std::uint64_t bits) { mWords[w] = bits; }
    /// Calls @p fn(index) for every bit set, in index order.
    template <class Fn> void forEachSet(const Fn& fn) const
    {
        for (std::size_t w = 0; w < mWords.size(); ++w)
            for (std::uint64_t b = mWords[w]; b; b &= b - 1)
                fn(w * 64 + std::size_t(__builtin_ctzll(b)));
    }
    /// The number of bits set.
    std::size_t count() const
    {
        std::size_t n = 0;
        for (const auto w : mWords)
            n += std::size_t(__builtin_popcountll(w));
        return n;
    }

private:
    std::vector<std::uint64_t> mWords;
};

} // namespace nebula
