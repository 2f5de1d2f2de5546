#pragma once
/// @file volume.h
/// Compact read-only volumes for the hot loops (DESIGN §9, STYLE "Determinism and speed"):
/// dense float arrays over the active bounding box, several channels interleaved per voxel,
/// with trilinear sampling in index space and the grid's affine index-to-world map.
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
/// integer index coordinates, as in OpenVDB), zero outside. Channel values of one voxel are
/// adjacent in memory, so one trilinear lookup fetches every channel.
class DenseVolume
{
public:
    DenseVolume() = default;
    DenseVolume(std::array<int, 3> lo, std::array<int, 3> dims, int channels);

    const std::array<int, 3>& lo() const { return mLo; }
    const std::array<int, 3>& dims() const { return mDims; }
    int channels() const { return mChannels; }
    std::size_t voxelCount() const { return std::size_t(mDims[0]) * mDims[1] * mDims[2]; }

    /// Linear voxel index of lattice point (i, j, k) (absolute index coordinates).
    std::size_t index(int i, int j, int k) const
    {
        return (std::size_t(k - mLo[2]) * mDims[1] + std::size_t(j - mLo[1])) * mDims[0] +
               std::size_t(i - mLo[0]);
    }
    bool contains(int i, int j, int k) const
    {
        return unsigned(i - mLo[0]) < unsigned(mDims[0]) &&
               unsigned(j - mLo[1]) < unsigned(mDims[1]) &&
               unsigned(k - mLo[2]) < unsigned(mDims[2]);
    }
    float* voxel(std::size_t idx) { return mData.data() + idx * std::size_t(mChannels); }
    const float* voxel(std::size_t idx) const
    {
        return mData.data() + idx * std::size_t(mChannels);
    }
    LargeFloatArray& data() { return mData; }
    const LargeFloatArray& data() const { return mData; }

    /// Channel @p c alone as a one-channel volume on the same lattice and transform.
    DenseVolume channel(int c) const
    {
        DenseVolume v(mLo, mDims, 1);
        v.indexToWorld = indexToWorld;
        for (std::size_t i = 0; i < voxelCount(); ++i)
            v.mData[i] = voxel(i)[c];
        return v;
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
        const std::size_t sx = std::size_t(mChannels), sy = sx * mDims[0], sz = sy * mDims[1];
        const float* b = mData.data() + index(ijk[0], ijk[1], ijk[2]) * sx + first;
        for (int c = 0; c < count; ++c) {
            const float* q = b + c;
            const float c00 = q[0] + u * (q[sx] - q[0]);
            const float c10 = q[sy] + u * (q[sy + sx] - q[sy]);
            const float c01 = q[sz] + u * (q[sz + sx] - q[sz]);
            const float c11 = q[sz + sy] + u * (q[sz + sy + sx] - q[sz + sy]);
            const float c0 = c00 + v * (c10 - c00);
            const float c1 = c01 + v * (c11 - c01);
            out[c] = c0 + w * (c1 - c0);
        }
    }

    /// Channel 0 at @p p (see sample()).
    float sample0(const Vec3& p) const
    {
        if (mChannels <= 16) {
            float v[16];
            sample(p, v);
            return v[0];
        }
        std::vector<float> v(static_cast<std::size_t>(mChannels));
        sample(p, v.data());
        return v[0];
    }

    Affine indexToWorld; ///< the source grid's affine map from index to world [pc]

private:
    std::array<int, 3> mLo{0, 0, 0};
    std::array<int, 3> mDims{0, 0, 0};
    int mChannels = 0;
    LargeFloatArray mData; ///< on huge pages when large (core/memory.h)
};

} // namespace nebula
