// SPDX-License-Identifier: Apache-2.0
/// @file noise.cpp
/// Perlin's improved noise (K. Perlin, "Improving Noise", SIGGRAPH 2002) and fBm on top of it.

#include "nebula/physics/noise.h"

#include "nebula/core/error.h"

#include <array>
#include <cmath>
#include <limits>
#include <string>

namespace nebula {

namespace {

/// Perlin's permutation of 0..255 from his reference implementation, stored twice so that
/// p[i + 1] and p[p[i] + j] never need wrapping.
constexpr std::array<int, 256> PERMUTATION = {
    151, 160, 137, 91,  90,  15,  131, 13,  201, 95,  96,  53,  194, 233, 7,   225, 140, 36,  103,
    30,  69,  142, 8,   99,  37,  240, 21,  10,  23,  190, 6,   148, 247, 120, 234, 75,  0,   26,
    197, 62,  94,  252, 219, 203, 117, 35,  11,  32,  57,  177, 33,  88,  237, 149, 56,  87,  174,
    20,  125, 136, 171, 168, 68,  175, 74,  165, 71,  134, 139, 48,  27,  166, 77,  146, 158, 231,
    83,  111, 229, 122, 60,  211, 133, 230, 220, 105, 92,  41,  55,  46,  245, 40,  244, 102, 143,
    54,  65,  25,  63,  161, 1,   216, 80,  73,  209, 76,  132, 187, 208, 89,  18,  169, 200, 196,
    135, 130, 116, 188, 159, 86,  164, 100, 109, 198, 173, 186, 3,   64,  52,  217, 226, 250, 124,
    123, 5,   202, 38,  147, 118, 126, 255, 82,  85,  212, 207, 206, 59,  227, 47,  16,  58,  17,
    182, 189, 28,  42,  223, 183, 170, 213, 119, 248, 152, 2,   44,  154, 163, 70,  221, 153, 101,
    155, 167, 43,  172, 9,   129, 22,  39,  253, 19,  98,  108, 110, 79,  113, 224, 232, 178, 185,
    112, 104, 218, 246, 97,  228, 251, 34,  242, 193, 238, 210, 144, 12,  191, 179, 162, 241, 81,
    51,  145, 235, 249, 14,  239, 107, 49,  192, 214, 31,  181, 199, 106, 157, 184, 84,  204, 176,
    115, 121, 50,  45,  127, 4,   150, 254, 138, 236, 205, 93,  222, 114, 67,  29,  24,  72,  243,
    141, 128, 195, 78,  66,  215, 61,  156, 180};

struct PermutationTable
{
    std::array<int, 512> p{};
    constexpr PermutationTable()
    {
        for (int i = 0; i < 256; ++i) {
            p[i] = PERMUTATION[i];
            p[i + 256] = PERMUTATION[i];
        }
    }
};

constexpr PermutationTable TABLE{};

/// Quintic fade 6t^5 - 15t^4 + 10t^3: zero first and second derivatives at t = 0 and 1.
inline double fade(double t)
{
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0);
}

inline double lerp(double t, double a, double b)
{
    return a + t * (b - a);
}

/// Dot product of (x, y, z) with one of 12 edge directions of a cube (16 hash values, four
/// of them repeated), exactly as in the reference code.
inline double grad(int hash, double x, double y, double z)
{
    const int h = hash & 15;
    const double u = h < 8 ? x : y;
    const double v = h < 4 ? y : (h == 12 || h == 14 ? x : z);
    return ((h & 1) == 0 ? u : -u) + ((h & 2) == 0 ? v : -v);
}

/// splitmix64 (Steele, Lea & Flood 2014): a small integer hash that turns a seed into a
/// stream of well-mixed 64-bit values; advances @p state.
inline std::uint64_t splitmix64(std::uint64_t& state)
{
    std::uint64_t z = (state += 0x9E3779B97F4A7C15ull);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
    return z ^ (z >> 31);
}

/// Uniform double in [0, 1) from the top 53 bits.
inline double unitDouble(std::uint64_t bits)
{
    return static_cast<double>(bits >> 11) * 0x1.0p-53;
}

/// Range of the per-octave offsets [noise lattice units]: large enough to decorrelate
/// seeds (the noise repeats every 256 units), small enough to keep double precision.
constexpr double OFFSET_RANGE = 4096.0;

void validateFbm(const FbmParams& params)
{
    if (params.octaves < 1 || params.octaves > 16) {
        throw UsageError("fbm: octaves must be in [1, 16], got " + std::to_string(params.octaves));
    }
    if (!(params.lacunarity > 0.0) || !std::isfinite(params.lacunarity)) {
        throw UsageError("fbm: lacunarity must be a finite number > 0, got " +
                         std::to_string(params.lacunarity));
    }
    if (!(params.gain > 0.0) || !std::isfinite(params.gain)) {
        throw UsageError("fbm: gain must be a finite number > 0, got " +
                         std::to_string(params.gain));
    }
}

/// Derivative of fade(): 30 t^4 - 60 t^3 + 30 t^2.
inline double fadeDerivative(double t)
{
    const double s = t * (t - 1.0);
    return 30.0 * s * s;
}

/// The octaves of fBm: validates @p params, then calls add(amplitude, frequency, px, py, pz)
/// for each octave with the point scaled by its frequency and shifted by its own offset drawn
/// from the seed's splitmix64 stream; returns the sum of the amplitudes.
template <class Add>
double forEachOctave(double x, double y, double z, const FbmParams& params, std::uint64_t seed,
                     Add&& add)
{
    validateFbm(params);
    std::uint64_t state = seed;
    double amplitudeSum = 0.0;
    double amplitude = 1.0;
    double frequency = 1.0;
    for (int i = 0; i < params.octaves; ++i) {
        const double ox = OFFSET_RANGE * unitDouble(splitmix64(state));
        const double oy = OFFSET_RANGE * unitDouble(splitmix64(state));
        const double oz = OFFSET_RANGE * unitDouble(splitmix64(state));
        add(amplitude, frequency, frequency * x + ox, frequency * y + oy, frequency * z + oz);
        amplitudeSum += amplitude;
        amplitude *= params.gain;
        frequency *= params.lacunarity;
    }
    return amplitudeSum;
}

/// The unit cube of the permutation lattice that contains (x, y, z) (wrapped to the table's
/// period of 256, as Java's `(int)Math.floor(x) & 255` does), the point's position inside it
/// and the hashes of the cube's corners (Perlin's AA, AB, BA, BB; +1 for z + 1). The input
/// must be finite.
struct LatticeCell
{
    double x, y, z;     ///< position inside the cube, [0, 1)
    int AA, AB, BA, BB; ///< corner hashes
};

inline LatticeCell latticeCell(double x, double y, double z)
{
    const auto& p = TABLE.p;
    const double fx = std::floor(x);
    const double fy = std::floor(y);
    const double fz = std::floor(z);
    const int X = static_cast<int>(std::fmod(fx, 256.0)) & 255;
    const int Y = static_cast<int>(std::fmod(fy, 256.0)) & 255;
    const int Z = static_cast<int>(std::fmod(fz, 256.0)) & 255;
    const int A = p[X] + Y;
    const int B = p[X + 1] + Y;
    return {x - fx, y - fy, z - fz, p[A] + Z, p[A + 1] + Z, p[B] + Z, p[B + 1] + Z};
}

} // namespace

double perlinNoise(double x, double y, double z)
{
    const auto& p = TABLE.p;

    // NaN or infinite input: no cube contains it (and converting it to int is undefined).
    if (!(std::isfinite(x) && std::isfinite(y) && std::isfinite(z))) {
        return std::numeric_limits<double>::quiet_NaN();
    }

    // The cube that contains the point, and fade curves.
    const LatticeCell cell = latticeCell(x, y, z);
    x = cell.x;
    y = cell.y;
    z = cell.z;
    const int AA = cell.AA, AB = cell.AB, BA = cell.BA, BB = cell.BB;
    const double u = fade(x);
    const double v = fade(y);
    const double w = fade(z);

    // Trilinear blend of the corner gradients.
    return lerp(
        w,
        lerp(v, lerp(u, grad(p[AA], x, y, z), grad(p[BA], x - 1, y, z)),
             lerp(u, grad(p[AB], x, y - 1, z), grad(p[BB], x - 1, y - 1, z))),
        lerp(v, lerp(u, grad(p[AA + 1], x, y, z - 1), grad(p[BA + 1], x - 1, y, z - 1)),
             lerp(u, grad(p[AB + 1], x, y - 1, z - 1), grad(p[BB + 1], x - 1, y - 1, z - 1))));
}

double fbm(double x, double y, double z, const FbmParams& params, std::uint64_t seed)
{
    double sum = 0.0;
    const double amplitudeSum = forEachOctave(
        x, y, z, params, seed, [&](double amplitude, double, double px, double py, double pz) {
            sum += amplitude * perlinNoise(px, py, pz);
        });
    return sum / amplitudeSum;
}

NoiseGradient perlinNoiseGradient(double x, double y, double z)
{
    const auto& p = TABLE.p;
    NoiseGradient out;
    if (!(std::isfinite(x) && std::isfinite(y) && std::isfinite(z))) {
        const double nan = std::numeric_limits<double>::quiet_NaN();
        out.value = nan;
        out.gradient = {nan, nan, nan};
        return out;
    }

    // Cube, hashes and fades exactly as in perlinNoise().
    const LatticeCell cell = latticeCell(x, y, z);
    x = cell.x;
    y = cell.y;
    z = cell.z;
    const int AA = cell.AA, AB = cell.AB, BA = cell.BA, BB = cell.BB;
    const double u = fade(x);
    const double v = fade(y);
    const double w = fade(z);

    // Corner hashes, indexed by (dx + 2 dy + 4 dz), and their dot products g.
    const int h[8] = {p[AA], p[BA], p[AB], p[BB], p[AA + 1], p[BA + 1], p[AB + 1], p[BB + 1]};
    double g[8];
    for (int c = 0; c < 8; ++c) {
        g[c] = grad(h[c], x - (c & 1), y - ((c >> 1) & 1), z - ((c >> 2) & 1));
    }
    out.value = lerp(w, lerp(v, lerp(u, g[0], g[1]), lerp(u, g[2], g[3])),
                     lerp(v, lerp(u, g[4], g[5]), lerp(u, g[6], g[7])));

    // d/dx of the blend = fade'(x) d(blend)/du + sum of blend weights times the corners'
    // gradient vectors (grad() is linear in its offset, so its unit-vector values give them).
    const double k1 = g[1] - g[0];
    const double k2 = g[2] - g[0];
    const double k3 = g[4] - g[0];
    const double k4 = g[0] - g[1] - g[2] + g[3];
    const double k5 = g[0] - g[2] - g[4] + g[6];
    const double k6 = g[0] - g[1] - g[4] + g[5];
    const double k7 = -g[0] + g[1] + g[2] - g[3] + g[4] - g[5] - g[6] + g[7];
    const double dBlend[3] = {k1 + k4 * v + k6 * w + k7 * v * w, k2 + k4 * u + k5 * w + k7 * u * w,
                              k3 + k5 * v + k6 * u + k7 * u * v};
    const double dFade[3] = {fadeDerivative(x), fadeDerivative(y), fadeDerivative(z)};
    for (int a = 0; a < 3; ++a) {
        double G[8];
        for (int c = 0; c < 8; ++c) {
            G[c] = grad(h[c], a == 0 ? 1.0 : 0.0, a == 1 ? 1.0 : 0.0, a == 2 ? 1.0 : 0.0);
        }
        const double weighted = lerp(w, lerp(v, lerp(u, G[0], G[1]), lerp(u, G[2], G[3])),
                                     lerp(v, lerp(u, G[4], G[5]), lerp(u, G[6], G[7])));
        out.gradient[a] = dFade[a] * dBlend[a] + weighted;
    }
    return out;
}

NoiseGradient fbmGradient(double x, double y, double z, const FbmParams& params, std::uint64_t seed)
{
    // The same sum as fbm(), with the chain rule's factor `frequency` on each gradient.
    NoiseGradient sum;
    const double amplitudeSum =
        forEachOctave(x, y, z, params, seed,
                      [&](double amplitude, double frequency, double px, double py, double pz) {
                          const NoiseGradient n = perlinNoiseGradient(px, py, pz);
                          sum.value += amplitude * n.value;
                          for (int a = 0; a < 3; ++a)
                              sum.gradient[a] += amplitude * frequency * n.gradient[a];
                      });
    sum.value /= amplitudeSum;
    for (auto& d : sum.gradient)
        d /= amplitudeSum;
    return sum;
}

std::array<double, 3> curlNoise(double x, double y, double z, const FbmParams& params,
                                std::uint64_t seed)
{
    // Three decorrelated seeds for the potential's components, from their own stream.
    std::uint64_t state = seed ^ 0x6A09E667F3BCC909ull;
    const std::uint64_t s0 = splitmix64(state);
    const std::uint64_t s1 = splitmix64(state);
    const std::uint64_t s2 = splitmix64(state);
    const auto psi0 = fbmGradient(x, y, z, params, s0).gradient;
    const auto psi1 = fbmGradient(x, y, z, params, s1).gradient;
    const auto psi2 = fbmGradient(x, y, z, params, s2).gradient;
    // curl psi = (d psi2/dy - d psi1/dz, d psi0/dz - d psi2/dx, d psi1/dx - d psi0/dy).
    return {psi2[1] - psi1[2], psi0[2] - psi2[0], psi1[0] - psi0[1]};
}

} // namespace nebula
