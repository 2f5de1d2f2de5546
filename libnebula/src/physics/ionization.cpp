// SPDX-License-Identifier: Apache-2.0
/// @file ionization.cpp
/// Photoionisation equilibrium by adaptive rays from every star: see ionization.h.

#include "nebula/physics/ionization.h"

#include "nebula/core/error.h"
#include "nebula/core/units.h"

#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>

namespace nebula {

namespace {

/// Rays start from BASE x BASE pixels per cube face (384 tasks) and split from there.
constexpr int BASE = 8;
/// The cube maps of the fronts (the overlap's shares) are at most BASE << MAP_LEVELS = 512
/// pixels a face edge: 6 MiB a map.
constexpr int MAP_LEVELS = 6;
/// The front of a ray that misses the lattice: beyond everything.
constexpr float MISS = 1e30f;

/// The cube-map face and face coordinates (u, v) in [-1, 1] of direction @p d.
struct FacePoint
{
    int face;
    double u, v;
};

FacePoint facePoint(const Vec3& d)
{
    const double ax = std::fabs(d.x), ay = std::fabs(d.y), az = std::fabs(d.z);
    const int a = (ax >= ay && ax >= az) ? 0 : (ay >= az ? 1 : 2);
    const double m = std::fabs(d[a]);
    return {2 * a + (d[a] < 0.0 ? 1 : 0), d[(a + 1) % 3] / m, d[(a + 2) % 3] / m};
}

Vec3 faceDirection(int face, double u, double v)
{
    const int a = face / 2;
    Vec3 d;
    d[a] = (face % 2) ? -1.0 : 1.0;
    d[(a + 1) % 3] = u;
    d[(a + 2) % 3] = v;
    return d.normalized();
}

/// Solid angle [sr] of the face rectangle [u0, u1] x [v0, v1].
double faceSolidAngle(double u0, double u1, double v0, double v1)
{
    const auto F = [](double u, double v) {
        return std::atan2(u * v, std::sqrt(1 + u * u + v * v));
    };
    return F(u1, v1) - F(u0, v1) - F(u1, v0) + F(u0, v0);
}

/// [r0, r1] of the ray o + r d inside the box [lo, hi]; r0 > r1 if it misses.
std::pair<double, double> clipRay(const Vec3& o, const Vec3& d, const Vec3& lo, const Vec3& hi)
{
    double r0 = 0.0, r1 = std::numeric_limits<double>::infinity();
    for (int a = 0; a < 3; ++a) {
        if (std::fabs(d[a]) < 1e-300) {
            if (o[a] < lo[a] || o[a] > hi[a]) return {1.0, 0.0};
            continue;
        }
        double t0 = (lo[a] - o[a]) / d[a], t1 = (hi[a] - o[a]) / d[a];
        if (t0 > t1) std::swap(t0, t1);
        r0 = std::max(r0, t0);
        r1 = std::min(r1, t1);
    }
    return {r0, r1};
}

/// Visits the voxels (cells [i - 1/2, i + 1/2]) that o + r d crosses for r in [ra, rb], in
/// order: f(i, j, k, r0, r1) returns false to stop.
template <class F> void walkVoxels(const Vec3& o, const Vec3& d, double ra, double rb, F&& f)
{
    if (!(rb > ra)) return;
    const Vec3 p = o + d * ra;
    int c[3], step[3];
    double next[3], delta[3];
    for (int a = 0; a < 3; ++a) {
        c[a] = int(std::floor(p[a] + 0.5));
        if (d[a] > 0) {
            step[a] = 1;
            delta[a] = 1.0 / d[a];
            next[a] = ra + (c[a] + 0.5 - p[a]) / d[a];
        } else if (d[a] < 0) {
            step[a] = -1;
            delta[a] = -1.0 / d[a];
            next[a] = ra + (c[a] - 0.5 - p[a]) / d[a];
        } else {
            step[a] = 0;
            delta[a] = std::numeric_limits<double>::infinity();
            next[a] = std::numeric_limits<double>::infinity();
        }
    }
    double r = ra;
    while (r < rb) {
        const int a = (next[0] <= next[1] && next[0] <= next[2]) ? 0 : (next[1] <= next[2] ? 1 : 2);
        const double r1 = std::min(next[a], rb);
        if (r1 > r && !f(c[0], c[1], c[2], r, r1)) return;
        r = r1;
        c[a] += step[a];
        next[a] += delta[a];
    }
}

} // namespace

/// Per voxel: the volume of the rays' tubes that cross it (channel 0), the parts of it in
/// front of the H front (1) and the He+ front (2), and the O++ fraction times the volume (3)
/// [voxels^3], as fixed-point sums (2^-20) stored by bricks where a ray passes: exact,
/// whatever order the threads add in.
struct IonizationSolver::Tally
{
    static constexpr int CH = 4;
    static constexpr std::size_t BRICK = SparseVolume::BRICK_VOXELS;
    static constexpr double SCALE = 1048576.0;

    explicit Tally(std::size_t voxels) : bricks((voxels + BRICK - 1) / BRICK) {}
    ~Tally()
    {
        for (auto& b : bricks)
            delete[] b.load();
    }
    Tally(const Tally&) = delete;
    Tally& operator=(const Tally&) = delete;

    void add(std::size_t idx, int ch, double volume)
    {
        std::uint32_t* b = brick(idx / BRICK);
        __atomic_fetch_add(&b[(idx % BRICK) * CH + ch], std::uint32_t(std::llround(volume * SCALE)),
                           __ATOMIC_RELAXED);
    }
    double get(std::size_t idx, int ch) const
    {
        const std::uint32_t* b = bricks[idx / BRICK].load(std::memory_order_acquire);
        return b ? b[(idx % BRICK) * CH + ch] / SCALE : 0.0;
    }

private:
    std::uint32_t* brick(std::size_t s)
    {
        std::uint32_t* p = bricks[s].load(std::memory_order_acquire);
        if (p) return p;
        auto* fresh = new std::uint32_t[BRICK * CH]();
        if (bricks[s].compare_exchange_strong(p, fresh, std::memory_order_acq_rel)) return fresh;
        delete[] fresh;
        return p;
    }
    std::vector<std::atomic<std::uint32_t*>> bricks;
};

/// The fronts of one star: cube maps of M x M pixels per face, the H and He+ fronts' distances
/// from the star [voxels] along each pixel's centre direction.
struct IonizationSolver::Maps
{
    int M = BASE;   ///< the maps' pixels a face edge: BASE << min(levels, MAP_LEVELS)
    int levels = 0; ///< the rays' finest level (BASE << levels rays a face edge)
    std::vector<float> h, he;
    double reach = 0.0; ///< the largest front distance short of MISS [voxels]

    /// The four pixels around direction @p d and their bilinear weights.
    struct Corners
    {
        std::size_t at[4];
        double weight[4];
    };
    Corners corners(const Vec3& d) const
    {
        const FacePoint fp = facePoint(d);
        const double px = std::clamp((fp.u + 1.0) * 0.5 * M - 0.5, 0.0, M - 1.0);
        const double py = std::clamp((fp.v + 1.0) * 0.5 * M - 0.5, 0.0, M - 1.0);
        const int i0 = std::min(int(px), M - 2), j0 = std::min(int(py), M - 2);
        const double fx = px - i0, fy = py - j0;
        const std::size_t base = (std::size_t(fp.face) * M + i0) * M + j0;
        return {{base, base + 1, base + M, base + M + 1},
                {(1 - fx) * (1 - fy), (1 - fx) * fy, fx * (1 - fy), fx * fy}};
    }
    /// The front distance in direction @p d, interpolated bilinearly.
    double lookup(const std::vector<float>& map, const Vec3& d) const
    {
        const Corners c = corners(d);
        double r = 0.0;
        for (int k = 0; k < 4; ++k)
            r += c.weight[k] * map[c.at[k]];
        return r;
    }
};

namespace {

/// The recombination and charge-exchange coefficients at one temperature [cm^3 s^-1].
struct Coefficients
{
    double h = 0, he = 0, o = 0, exchange = 0, T = 0;
    Coefficients() = default;
    explicit Coefficients(double t)
        : h(caseBRecombinationH(t)), he(caseBRecombinationHe(t)), o(recombinationOIII(t)),
          exchange(chargeExchangeOIII(t)), T(t)
    {}
};

} // namespace

/// The thermal balance's temperature as a table over log n_e, He+/He and O++/O of the ionised
/// gas (thermalBalanceTemperature at the nodes, trilinear between them): a few thousand
/// balances once per solve instead of one per voxel and ray.
struct IonizationSolver::Thermal
{
    static constexpr int NF = 21, NH = 5, NN = 37; ///< O++/O, He+/He, log10 n_e nodes
    static constexpr double LOG_NE0 = -2.0, LOG_NE_STEP = 0.25;

    Thermal(const Abundances& ab, const PhotoHeating& heat) : table(std::size_t(NF) * NH * NN)
    {
        tbb::parallel_for(0, NN, [&](int c) {
            for (int b = 0; b < NH; ++b)
                for (int a = 0; a < NF; ++a) {
                    const double heii = double(b) / (NH - 1),
                                 ne = std::pow(10.0, LOG_NE0 + LOG_NE_STEP * c);
                    const IonisedGas gas{ne / (1.0 + ab.he * heii), heii, double(a) / (NF - 1)};
                    table[(std::size_t(c) * NH + b) * NF + a] =
                        Coefficients(thermalBalanceTemperature(gas, ab, heat));
                }
        });
    }
    /// T_e [K] and its coefficients for ionised gas of electron density @p ne [cm^-3], He+/He
    /// @p heii and O++/O @p oiii (each interpolated between the nodes).
    Coefficients operator()(double ne, double heii, double oiii) const
    {
        const double fc =
            std::clamp((std::log10(std::max(ne, 1e-30)) - LOG_NE0) / LOG_NE_STEP, 0.0, NN - 1.0);
        const double fb = std::clamp(heii, 0.0, 1.0) * (NH - 1);
        const double fa = std::clamp(oiii, 0.0, 1.0) * (NF - 1);
        const int c = std::min(int(fc), NN - 2), b = std::min(int(fb), NH - 2),
                  a = std::min(int(fa), NF - 2);
        const double wc = fc - c, wb = fb - b, wa = fa - a;
        Coefficients out;
        out.T = 0.0;
        for (int k = 0; k < 8; ++k) {
            const int dc = k >> 2, db = (k >> 1) & 1, da = k & 1;
            const double w = (dc ? wc : 1 - wc) * (db ? wb : 1 - wb) * (da ? wa : 1 - wa);
            if (w == 0.0) continue;
            const Coefficients& n = table[(std::size_t(c + dc) * NH + b + db) * NF + a + da];
            out.T += w * n.T;
            out.h += w * n.h;
            out.he += w * n.he;
            out.o += w * n.o;
            out.exchange += w * n.exchange;
        }
        return out;
    }
    std::vector<Coefficients> table;
};

namespace {

/// The grid's electron temperature of voxel @p idx [K] (channel 1 where > 0), else 0.
double gridTemperature(const SparseVolume& n, std::size_t idx)
{
    if (n.channels() < 2) return 0.0;
    const double t = n.voxel(idx)[1];
    return t > 0.0 ? t : 0.0;
}

/// O++/O where O+ is photoionised at @p gammaO [s^-1] against recombination and charge
/// exchange with the residual H0 (its fraction from H's balance at @p gammaH [s^-1]).
double oiiiBalance(double gammaO, double gammaH, double ne, double nH, const Coefficients& c)
{
    if (!(gammaO > 0.0)) return 0.0;
    const double xH0 = c.h * ne / (gammaH + c.h * ne);
    return gammaO / (gammaO + c.o * ne + c.exchange * nH * xH0);
}

/// He+ recombination straight to the ground level 1 1S [cm^3 s^-1] (AGN2 Table 2.4, 10^4 K;
/// its weak T-dependence left out), and the H0 and He0 cross-sections at 24.6 eV [cm^2]:
/// the photon it emits ionises H0 instead of He0 with probability y = n_H0 sigma_H /
/// (n_H0 sigma_H + n_He0 sigma_He) (AGN2 §2.4), so He0 recombines at alpha_B + y alpha_1.
constexpr double ALPHA_HE_GROUND = 1.59e-13;
constexpr double SIGMA_H_24 = 6.30e-18 * (H_IONIZATION_EV / HE_IONIZATION_EV) *
                              (H_IONIZATION_EV / HE_IONIZATION_EV) *
                              (H_IONIZATION_EV / HE_IONIZATION_EV);
constexpr double SIGMA_HE_24 = 7.83e-18;

/// How wide a ray may grow through empty space before it splits [voxels].
constexpr double DEFER = 8.0;

/// Bricks of 8^3 voxels of the lattice with gas in them or in a neighbouring brick.
class BrickOccupancy
{
public:
    explicit BrickOccupancy(const SparseVolume& n) : mLo(n.lo())
    {
        const auto dims = n.dims();
        for (int a = 0; a < 3; ++a)
            mBricks[a] = (dims[a] + 7) / 8;
        std::vector<std::uint8_t> gas(std::size_t(mBricks[0]) * mBricks[1] * mBricks[2], 0);
        tbb::parallel_for(0, mBricks[2], [&](int bz) {
            for (int by = 0; by < mBricks[1]; ++by)
                for (int bx = 0; bx < mBricks[0]; ++bx) {
                    bool any = false;
                    for (int k = bz * 8; k < std::min(bz * 8 + 8, dims[2]) && !any; ++k)
                        for (int j = by * 8; j < std::min(by * 8 + 8, dims[1]) && !any; ++j)
                            for (int i = bx * 8; i < std::min(bx * 8 + 8, dims[0]); ++i) {
                                const std::size_t idx = n.index(i + mLo[0], j + mLo[1], k + mLo[2]);
                                if (n.stored(idx) && n.voxel(idx)[0] > 0.0f) {
                                    any = true;
                                    break;
                                }
                            }
                    gas[brick(bx, by, bz)] = any;
                }
        });
        mNear.assign(gas.size(), 0);
        for (int bz = 0; bz < mBricks[2]; ++bz)
            for (int by = 0; by < mBricks[1]; ++by)
                for (int bx = 0; bx < mBricks[0]; ++bx) {
                    if (!gas[brick(bx, by, bz)]) continue;
                    for (int dz = -1; dz <= 1; ++dz)
                        for (int dy = -1; dy <= 1; ++dy)
                            for (int dx = -1; dx <= 1; ++dx) {
                                const int x = bx + dx, y = by + dy, z = bz + dz;
                                if (x < 0 || y < 0 || z < 0 || x >= mBricks[0] || y >= mBricks[1] ||
                                    z >= mBricks[2])
                                    continue;
                                mNear[brick(x, y, z)] = 1;
                            }
                }
    }
    /// Whether the voxel at index-space point @p p is near gas.
    bool near(const Vec3& p) const
    {
        return near(int(std::floor(p.x + 0.5)), int(std::floor(p.y + 0.5)),
                    int(std::floor(p.z + 0.5)));
    }
    /// Whether voxel (i, j, k) is in or next to a brick with gas (false off the lattice).
    bool near(int i, int j, int k) const
    {
        const int x = (i - mLo[0]) >> 3, y = (j - mLo[1]) >> 3, z = (k - mLo[2]) >> 3;
        if (i < mLo[0] || j < mLo[1] || k < mLo[2] || x >= mBricks[0] || y >= mBricks[1] ||
            z >= mBricks[2])
            return false;
        return mNear[brick(x, y, z)] != 0;
    }

private:
    std::size_t brick(int x, int y, int z) const
    {
        return (std::size_t(z) * mBricks[1] + y) * mBricks[0] + x;
    }
    std::array<int, 3> mLo;
    int mBricks[3];
    std::vector<std::uint8_t> mNear;
};

/// The photons' tally of one base ray and its children.
struct RayTally
{
    double recombined = 0, dust = 0, escaped = 0, open = 0, volume = 0;
    double spared = 0; ///< recombinations other stars paid for, by their shares [s^-1]
    void add(const RayTally& o)
    {
        spared += o.spared;
        recombined += o.recombined;
        dust += o.dust;
        escaped += o.escaped;
        open += o.open;
        volume += o.volume;
    }
};

/// What a ray carries [photons s^-1 sr^-1]: above 13.6 eV, above 24.6 eV and above 35.1 eV;
/// where its He+ zone ended (< 0: not yet) [voxels]; the last voxel's coefficients.
struct RayState
{
    double qH = 0, qHe = 0, qO = 0, rHe = -1;
    Coefficients last; ///< at the last voxel's T_e (T = 0: none yet)
};

/// One star's march over its rays (one iteration).
class StarMarch
{
public:
    StarMarch(const SparseVolume& n, const std::vector<IonizingStar>& stars, std::size_t s,
              const IonizationParams& p, const std::vector<IonizationSolver::Maps*>& previous,
              IonizationSolver::Maps& out, IonizationSolver::Tally& tally,
              const BrickOccupancy& occupied, const IonizationSolver::Thermal* thermal)
        : mN(n), mStars(stars), mS(s), mP(p), mPrevious(previous), mOut(out), mTally(tally),
          mOccupied(occupied), mThermal(thermal), mFixed(p.electronTemperature),
          mBands(bandCrossSections(stars[s].temperature))
    {
        const auto lo = n.lo(), dims = n.dims();
        mLo = Vec3(lo[0] - 0.5, lo[1] - 0.5, lo[2] - 0.5);
        mHi = Vec3(lo[0] + dims[0] - 0.5, lo[1] + dims[1] - 0.5, lo[2] + dims[2] - 0.5);
        mDx3 = p.voxelSizeCm * p.voxelSizeCm * p.voxelSizeCm;
        mDust = p.dustCrossSection * p.voxelSizeCm;
    }

    RayTally trace(int face, int level, int i, int j, double r, RayState st) const
    {
        const int Ml = BASE << level;
        const double u0 = -1.0 + 2.0 * i / Ml, v0 = -1.0 + 2.0 * j / Ml, w = 2.0 / Ml;
        const Vec3 d = faceDirection(face, u0 + w / 2, v0 + w / 2);
        const Vec3 o = mStars[mS].position;
        const double omega = faceSolidAngle(u0, u0 + w, v0, v0 + w);
        RayTally tally;
        const auto [enter, exit] = clipRay(o, d, mLo, mHi);
        if (!(exit > enter) || exit <= r) { // misses the lattice, or has left it
            const bool miss = !(exit > enter);
            const float far = miss ? MISS : float(exit + 2.0);
            tally.escaped += st.qH * omega;
            tally.open += omega;
            record(face, level, i, j, far, st.rHe >= 0 ? float(st.rHe) : far);
            if (!miss) tally.volume += omega * exit * exit * exit / 3;
            return tally;
        }
        // The ray splits once wider than raySpacing where gas is near; through empty space it
        // may widen to DEFER voxels first (its children, within DEFER / 2 of its line, are
        // in empty bricks too while it is).
        const double split = level < mOut.levels ? mP.raySpacing * Ml / 2.0 : exit;
        const double hard = level < mOut.levels ? std::max(split, DEFER * Ml / 2.0) : exit;
        double rEnd = std::min(exit, std::max(split, r));
        double rFront = -1.0;
        walkVoxels(o, d, std::max(r, enter), rEnd, [&](int ci, int cj, int ck, double a, double b) {
            return pay(ci, cj, ck, a, b, omega, st, tally, rFront);
        });
        if (rFront < 0.0 && rEnd < exit && rEnd < hard &&
            !mOccupied.near(o + d * rEnd)) { // empty space: widen on to the next gas
            double stop = -1.0;
            walkVoxels(o, d, rEnd, std::min(exit, hard),
                       [&](int ci, int cj, int ck, double a, double) {
                           if (!mOccupied.near(ci, cj, ck)) return true;
                           stop = a;
                           return false;
                       });
            rEnd = stop >= 0.0 ? stop : std::min(exit, hard);
        }
        if (rFront >= 0) {
            // The ray's volume beyond its front, out of the lattice (it splits no more), so
            // that a voxel other rays ionise counts this ray's part of it as neutral.
            walkVoxels(o, d, rFront, exit, [&](int ci, int cj, int ck, double a, double b) {
                if (density(ci, cj, ck) > 0.0) {
                    mTally.add(mN.index(ci, cj, ck), 0, omega * (b * b * b - a * a * a) / 3.0);
                }
                return true;
            });
            const double he = st.rHe >= 0 ? std::min(st.rHe, rFront) : rFront;
            record(face, level, i, j, float(rFront), float(he));
            tally.volume += omega * rFront * rFront * rFront / 3;
            return tally;
        }
        if (rEnd >= exit) { // photons leave the grid
            const float far = float(exit + 2.0);
            tally.escaped += st.qH * omega;
            tally.open += omega;
            record(face, level, i, j, far, st.rHe >= 0 ? float(st.rHe) : far);
            tally.volume += omega * exit * exit * exit / 3;
            return tally;
        }
        for (int c = 0; c < 4; ++c)
            tally.add(trace(face, level + 1, 2 * i + (c & 1), 2 * j + (c >> 1), rEnd, st));
        return tally;
    }

private:
    /// The ray's stretch [a, b] through voxel (ci, cj, ck) of a ray of solid angle @p omega:
    /// pays its recombinations from @p st, tallies its ionised volume, and sets @p rFront
    /// where the H-ionising photons run out. Returns false there.
    bool pay(int ci, int cj, int ck, double a, double b, double omega, RayState& st,
             RayTally& tally, double& rFront) const
    {
        const double n = density(ci, cj, ck);
        if (n <= 0.0) return true;
        const std::size_t idx = mN.index(ci, cj, ck);
        const auto tube = [&](double r0, double r1) {
            return omega * (r1 * r1 * r1 - r0 * r0 * r0) / 3.0;
        };
        const double share = shareAt(ci, cj, ck);
        const bool heZone = st.rHe < 0 && st.qHe > 0;
        const double ne = n * (1.0 + (heZone ? mP.abundances.he : 0.0));
        // The local fluxes [cm^-2 s^-1] per photon of q, at the stretch's middle.
        const double rMid = std::max(0.5 * (a + b), 0.5) * mP.voxelSizeCm;
        const double perQ = 1.0 / (rMid * rMid);
        const double gammaH = mBands.hAll * st.qH * perQ;
        const double gammaO = heZone ? mBands.oHard * st.qO * perQ : 0.0;
        double oiii = 0.0;
        const Coefficients c = coefficients(idx, ne, n, heZone, gammaH, gammaO, st.last, oiii);
        st.last = c;
        const double volume = mDx3 * n * share * (b * b * b - a * a * a) / 3.0; // per ne, alpha
        const double need = c.h * ne * volume;
        double heEnd = heZone ? b : a; // the He+ zone's part of this voxel ends here
        if (heZone) {
            const double soft = mBands.heSoft * std::max(st.qHe - st.qO, 0.0),
                         hardHe = mBands.heHard * st.qO;
            // The residual neutrals from the local balances; the share y of the He ground
            // recombinations' photons that H0 takes.
            const double xH0 = c.h * ne / (gammaH + c.h * ne);
            const double xHe0 = c.he * ne / ((soft + hardHe) * perQ + c.he * ne);
            const double hAbsorbs = xH0 * SIGMA_H_24,
                         heAbsorbs = mP.abundances.he * xHe0 * SIGMA_HE_24;
            const double y = hAbsorbs / std::max(hAbsorbs + heAbsorbs, 1e-300);
            const double needHe = (c.he + y * ALPHA_HE_GROUND) * ne * mP.abundances.he * volume;
            // The hard photons' share of the He0 and H0 photoionisations (by sigma q), and
            // the O++ recombinations they balance.
            const double needO =
                needHe * hardHe / std::max(soft + hardHe, 1e-300) +
                need * mBands.hHard * st.qO / std::max(mBands.hAll * st.qH, 1e-300) +
                c.o * ne * mP.abundances.o * oiii * volume;
            if (st.qHe <= needHe) {
                st.rHe = std::cbrt(a * a * a + (b * b * b - a * a * a) * st.qHe / needHe);
                heEnd = st.rHe;
                st.qHe = 0;
                st.qO = 0;
            } else {
                st.qHe -= needHe;
                st.qO = std::min(std::max(st.qO - needO, 0.0), st.qHe);
            }
        }
        if (st.qH <= need) {
            rFront = std::cbrt(a * a * a + (b * b * b - a * a * a) * st.qH / need);
            mTally.add(idx, 0, tube(a, rFront)); // the rest: the walk beyond the front
            mTally.add(idx, 1, tube(a, rFront));
            mTally.add(idx, 2, tube(a, std::min(heEnd, rFront)));
            mTally.add(idx, 3, oiii * tube(a, std::min(heEnd, rFront)));
            tally.recombined += st.qH * omega;
            tally.spared += st.qH * omega * (1.0 / share - 1.0);
            st.qH = 0;
            return false;
        }
        mTally.add(idx, 0, tube(a, b));
        mTally.add(idx, 1, tube(a, b));
        mTally.add(idx, 2, tube(a, heEnd));
        mTally.add(idx, 3, oiii * tube(a, heEnd));
        st.qH -= need;
        tally.recombined += need * omega;
        tally.spared += need * omega * (1.0 / share - 1.0);
        if (mDust > 0) {
            const double keep = std::exp(-mDust * n * (b - a));
            tally.dust += st.qH * (1 - keep) * omega;
            st.qH *= keep;
            st.qHe *= keep;
            st.qO *= keep;
        }
        return true;
    }

    /// The coefficients at the voxel's T_e, and its O++/O (@p oiii): the grid's T_e, else the
    /// fixed one, else the thermal balance's at the O++/O found at the ray's last T_e @p last.
    Coefficients coefficients(std::size_t idx, double ne, double n, bool heZone, double gammaH,
                              double gammaO, const Coefficients& last, double& oiii) const
    {
        const double grid = gridTemperature(mN, idx);
        if (grid > 0.0 || !mThermal) {
            const Coefficients c = grid > 0.0 ? Coefficients(grid) : mFixed;
            oiii = oiiiBalance(gammaO, gammaH, ne, n, c);
            return c;
        }
        oiii = oiiiBalance(gammaO, gammaH, ne, n, last.T > 0.0 ? last : mFixed);
        const Coefficients c = (*mThermal)(ne, heZone ? 1.0 : 0.0, oiii);
        if (gammaO > 0.0) oiii = oiiiBalance(gammaO, gammaH, ne, n, c);
        return c;
    }
    double density(int i, int j, int k) const
    {
        return mN.contains(i, j, k) ? double(mN.voxel(mN.index(i, j, k))[0]) : 0.0;
    }

    /// This star's share of the recombinations at voxel (i, j, k): its flux Q / r^2 over the
    /// sum of those of the stars whose previous fronts reach the voxel. The first pass takes
    /// every star to reach it (fronts are nearest the converged ones for a cluster, whose
    /// stars light the same gas: 2 passes instead of 4 for pillars' three).
    double shareAt(int i, int j, int k) const
    {
        if (mStars.size() < 2) return 1.0;
        const Vec3 c(i, j, k);
        const auto weight = [&](std::size_t t) {
            const double r2 = std::max((c - mStars[t].position).dot(c - mStars[t].position), 0.25);
            return mStars[t].rates.h / r2;
        };
        const double own = weight(mS);
        double all = own;
        for (std::size_t t = 0; t < mStars.size(); ++t) {
            if (t == mS) continue;
            if (mPrevious.empty()) {
                all += weight(t);
                continue;
            }
            const Vec3 d = c - mStars[t].position;
            const double r = d.length();
            const auto& maps = *mPrevious[t];
            if (r >= maps.reach || r <= 0.0) continue;
            if (r < maps.lookup(maps.h, d * (1.0 / r))) all += weight(t);
        }
        return own / all;
    }

    /// Writes a finished ray's fronts into the maps: over its pixels, or, for a ray finer than
    /// the maps, into the one pixel it starts (the first of the pixel's rays writes it).
    void record(int face, int level, int i, int j, float rH, float rHe) const
    {
        const int M = mOut.M, Ml = BASE << level;
        if (Ml > M) {
            const int ratio = Ml / M;
            if (i % ratio || j % ratio) return;
            i /= ratio;
            j /= ratio;
            level -= __builtin_ctz(unsigned(ratio));
        }
        const int s = M / (BASE << level);
        for (int a = i * s; a < (i + 1) * s; ++a) {
            float* row = &mOut.h[(std::size_t(face) * M + a) * M];
            float* rowHe = &mOut.he[(std::size_t(face) * M + a) * M];
            for (int b = j * s; b < (j + 1) * s; ++b) {
                row[b] = rH;
                rowHe[b] = rHe;
            }
        }
    }

    const SparseVolume& mN;
    const std::vector<IonizingStar>& mStars;
    std::size_t mS;
    const IonizationParams& mP;
    const std::vector<IonizationSolver::Maps*>& mPrevious;
    IonizationSolver::Maps& mOut;
    IonizationSolver::Tally& mTally;
    const BrickOccupancy& mOccupied;
    const IonizationSolver::Thermal* mThermal; ///< null: no thermal balance
    Coefficients mFixed;                       ///< at IonizationParams::electronTemperature
    BandCrossSections mBands;                  ///< the star's
    Vec3 mLo, mHi;
    double mDust = 0, mDx3 = 0;
};

/// The finest level a star's rays need: footprints of at most raySpacing at the lattice's
/// farthest corner (capped at 4096 pixels a face edge).
int finestLevel(const SparseVolume& n, const Vec3& star, double spacing)
{
    const auto lo = n.lo(), dims = n.dims();
    double far = 1.0;
    for (int c = 0; c < 8; ++c) {
        const Vec3 corner(lo[0] - 0.5 + ((c & 1) ? dims[0] : 0),
                          lo[1] - 0.5 + ((c & 2) ? dims[1] : 0),
                          lo[2] - 0.5 + ((c & 4) ? dims[2] : 0));
        far = std::max(far, (corner - star).length());
    }
    int level = 0;
    while ((BASE << level) * spacing < 2.0 * far && (BASE << level) < 4096)
        ++level;
    return level;
}

/// Whether any two stars' fronts may reach the same voxel.
bool overlapping(const std::vector<IonizingStar>& stars,
                 const std::vector<IonizationSolver::Maps*>& maps)
{
    for (std::size_t s = 0; s < stars.size(); ++s)
        for (std::size_t t = s + 1; t < stars.size(); ++t)
            if ((stars[s].position - stars[t].position).length() < maps[s]->reach + maps[t]->reach)
                return true;
    return false;
}

} // namespace

IonizationSolver::IonizationSolver(const SparseVolume& density, std::vector<IonizingStar> stars,
                                   const IonizationParams& params)
    : mDensity(density), mStars(std::move(stars)), mParams(params)
{
    if (!(params.voxelSizeCm > 0.0)) throw Error("ionisation: the voxel size must be > 0");
    if (!(params.raySpacing > 0.0)) throw Error("ionisation: the ray spacing must be > 0");
    PhotoHeating heat;
    double photons = 0.0;
    for (const auto& star : mStars) {
        mMaps.push_back(new Maps);
        mTallies.push_back(nullptr);
        mFrontCrossSection.push_back(meanHydrogenCrossSection(star.temperature));
        if (!params.thermalBalance || !(star.rates.h > 0.0)) continue;
        const PhotoHeating h = blackbodyHeating(star.temperature);
        heat.h += h.h * star.rates.h;
        heat.he += h.he * star.rates.h;
        photons += star.rates.h;
    }
    if (params.thermalBalance) { // the stars' photoheating, weighted by their Q(H0)
        heat.h /= std::max(photons, 1e-300);
        heat.he /= std::max(photons, 1e-300);
        mThermal = new Thermal(params.abundances, heat);
    }
}

IonizationSolver::~IonizationSolver()
{
    for (auto* m : mMaps)
        delete m;
    for (auto* t : mTallies)
        delete t;
    delete mThermal;
}

void IonizationSolver::solve(const Run* run)
{
    const std::size_t S = mStars.size();
    mPhotons.assign(S, {});
    std::vector<Maps*> previous;
    std::vector<Maps> saved(S);
    std::vector<double> lastVolume(S, -1.0);
    bool overlapBefore = true;
    const BrickOccupancy occupied(mDensity);
    mIterations = 0;
    for (int it = 0; it < std::max(1, mParams.maxIterations); ++it) {
        ++mIterations;
        double spared = 0.0, photons = 0.0, change = 0.0;
        for (std::size_t s = 0; s < S; ++s) {
            Maps& maps = *mMaps[s];
            maps.levels = finestLevel(mDensity, mStars[s].position, mParams.raySpacing);
            maps.M = BASE << std::min(maps.levels, MAP_LEVELS);
            maps.h.assign(std::size_t(6) * maps.M * maps.M, 0.0f);
            maps.he.assign(maps.h.size(), 0.0f);
            delete mTallies[s];
            mTallies[s] = nullptr;
            mTallies[s] = new Tally(mDensity.voxelCount());
            const StarMarch march(mDensity, mStars, s, mParams, previous, maps, *mTallies[s],
                                  occupied, mThermal);
            RayState start;
            start.qH = mStars[s].rates.h * INV_FOUR_PI;
            start.qHe = mStars[s].rates.he * INV_FOUR_PI;
            start.qO = std::min(mStars[s].rates.oiii, mStars[s].rates.he) * INV_FOUR_PI;
            std::vector<RayTally> tallies(std::size_t(6) * BASE * BASE);
            Progress bar(run, (run ? run->tool() + " " : std::string()) + mStars[s].name,
                         tallies.size());
            tbb::parallel_for(std::size_t(0), tallies.size(), [&](std::size_t t) {
                if (run) run->checkCancel();
                const int face = int(t / (BASE * BASE)), i = int(t / BASE % BASE),
                          j = int(t % BASE);
                tallies[t] = march.trace(face, 0, i, j, 0.0, start);
                bar.add(1);
            });
            RayTally total;
            for (const auto& t : tallies)
                total.add(t);
            spared += total.spared;
            photons += mStars[s].rates.h;
            mPhotons[s] = {mStars[s].rates.h, total.recombined, total.dust, total.escaped,
                           total.open};
            double reach = 0.0;
            for (float r : maps.h)
                if (r < MISS) reach = std::max(reach, double(r));
            maps.reach = reach + 2.0;
            // The largest relative change of a star's ionised volume (from none: infinite).
            if (lastVolume[s] >= 0.0 && total.volume != lastVolume[s]) {
                change = std::max(change, lastVolume[s] > 0.0
                                              ? std::fabs(total.volume / lastVolume[s] - 1.0)
                                              : std::numeric_limits<double>::infinity());
            }
            lastVolume[s] = total.volume;
        }
        if (run && S > 1) {
            run->info("pass " + std::to_string(mIterations) + ": the overlap's shares spared " +
                      std::to_string(spared / photons) +
                      " of the stars' photons; the ionised volumes changed by " +
                      std::to_string(change) + " at most");
        }
        // Done when the fronts stop moving, or when the overlap's shares moved fewer photons
        // than the tolerance (another pass would change less), or when the fronts do not
        // overlap and did not before (the shares were then all 1: exact). The first pass took
        // every star to reach everywhere: a second always follows it.
        const bool moved = mIterations == 1 || change > mParams.tolerance;
        if (S < 2 || !moved) break;
        const bool overlap = overlapping(mStars, mMaps);
        if (!overlap && !previous.empty() && !overlapBefore) break;
        overlapBefore = overlap;
        if (!previous.empty() && spared < mParams.tolerance * photons) break;
        for (std::size_t s = 0; s < S; ++s)
            saved[s] = *mMaps[s];
        previous.clear();
        for (auto& m : saved)
            previous.push_back(&m);
    }
}

double IonizationSolver::frontDistance(std::size_t s, const Vec3& d) const
{
    return mMaps.at(s)->lookup(mMaps[s]->h, d.normalized());
}

VoxelIonization IonizationSolver::at(int i, int j, int k) const
{
    VoxelIonization out;
    if (!mDensity.contains(i, j, k)) return out;
    const std::size_t idx = mDensity.index(i, j, k);
    const double n = mDensity.voxel(idx)[0];
    if (!(n > 0.0)) return out;
    const Vec3 c(i, j, k);
    const double grid = gridTemperature(mDensity, idx), y = mParams.abundances.he;
    double layer = 0.0, tSum = 0.0, tWeight = 0.0;
    for (std::size_t s = 0; s < mStars.size(); ++s) {
        const Vec3 d = c - mStars[s].position;
        const double r = d.length();
        double xH = 1.0, xHe = 1.0, xO = 0.0, h = 0.5;
        if (r > 1e-9) {
            const Vec3 u = d * (1.0 / r);
            h = 0.5 * (std::fabs(u.x) + std::fabs(u.y) + std::fabs(u.z));
            // The rays' ionised share of the volume they cross here (none crossed: neutral).
            const auto& tally = *mTallies[s];
            const double tube = tally.get(idx, 0);
            xH = tube > 0 ? std::min(1.0, tally.get(idx, 1) / tube) : 0.0;
            xHe = tube > 0 ? std::min(xH, tally.get(idx, 2) / tube) : 0.0;
            xO = tube > 0 ? std::min(xHe, tally.get(idx, 3) / tube) : 0.0;
        }
        if (xH > 0.0 && xH < 1.0 && xH > out.hii) {
            // The partly ionised layer, one photon mean free path thick, in the voxel's slab
            // of width 2h that the front crosses.
            const double path = 1.0 / (n * mFrontCrossSection[s] * mParams.voxelSizeCm);
            layer = std::min(1.0, path / (2.0 * h));
        }
        out.hii = std::max(out.hii, xH);
        out.heii = std::max(out.heii, xHe);
        out.oiii = std::max(out.oiii, xO);
        if (mThermal && grid <= 0.0 && xH > 0.0) {
            // Each star's rays found the balance at their own He+ and O++; where H II regions
            // overlap, T_e is the mean of theirs weighted as the recombinations are shared
            // (by Q / r^2), so that the grid's recombinations stay the ones the rays paid.
            const double w = mStars[s].rates.h / std::max(r * r, 0.25);
            tSum += w * (*mThermal)(n * (1.0 + y * xHe / xH), xHe / xH, xO / xH).T;
            tWeight += w;
        }
    }
    out.front = out.hii < 1.0 ? std::min(layer, 1.0 - out.hii) : 0.0;
    out.ne = n * (1.0 + (out.hii > 0.0 ? y * out.heii / out.hii : 0.0));
    out.te = grid > 0.0 ? grid : (tWeight > 0.0 ? tSum / tWeight : mParams.electronTemperature);
    return out;
}

std::vector<float> ionizationReference(const SparseVolume& density, const IonizingStar& star,
                                       const IonizationParams& params, int samples)
{
    const auto lo = density.lo(), dims = density.dims();
    const Vec3 boxLo(lo[0] - 0.5, lo[1] - 0.5, lo[2] - 0.5);
    const Vec3 boxHi(lo[0] + dims[0] - 0.5, lo[1] + dims[1] - 0.5, lo[2] + dims[2] - 0.5);
    const double alpha =
        caseBRecombinationH(params.electronTemperature) * std::pow(params.voxelSizeCm, 3);
    const double q0 = star.rates.h / (4.0 * PI);
    // Whether point p is ionised: the recombinations alpha n^2 r^2 dr of the voxels on the
    // straight line from the star to p use up less than Q / 4 pi.
    const auto ionised = [&](const Vec3& p) {
        const Vec3 d = p - star.position;
        const double r = d.length();
        if (r < 1e-12) return true;
        const Vec3 u = d * (1.0 / r);
        double q = q0;
        const auto [enter, exit] = clipRay(star.position, u, boxLo, boxHi);
        walkVoxels(star.position, u, std::max(0.0, enter), std::min(exit, r),
                   [&](int a, int b, int e, double r0, double r1) {
                       const double n = density.contains(a, b, e)
                                            ? density.voxel(density.index(a, b, e))[0]
                                            : 0.0;
                       q -= alpha * n * n * (r1 * r1 * r1 - r0 * r0 * r0) / 3.0;
                       return q > 0.0;
                   });
        return q > 0.0;
    };
    std::vector<float> out(density.voxelCount(), 0.0f);
    for (int k = lo[2]; k < lo[2] + dims[2]; ++k)
        for (int j = lo[1]; j < lo[1] + dims[1]; ++j)
            for (int i = lo[0]; i < lo[0] + dims[0]; ++i) {
                // Voxels whose 27 points (corners, edge and face centres, centre) agree are
                // whole (the fronts of the reference's uses are smooth on a voxel's scale);
                // the others are sampled.
                int agree = 0;
                for (int c = 0; c < 27; ++c) {
                    const Vec3 q(i + 0.499 * (c % 3 - 1), j + 0.499 * (c / 3 % 3 - 1),
                                 k + 0.499 * (c / 9 - 1));
                    agree += ionised(q) ? 1 : 0;
                }
                if (agree == 0 || agree == 27) {
                    out[density.index(i, j, k)] = agree ? 1.0f : 0.0f;
                    continue;
                }
                // Columns along the axis nearest the direction from the star: each crosses
                // the front at most once there; bisection finds where.
                const Vec3 c(i, j, k), radial = c - star.position;
                const int axis = std::fabs(radial.x) >= std::fabs(radial.y) &&
                                         std::fabs(radial.x) >= std::fabs(radial.z)
                                     ? 0
                                     : (std::fabs(radial.y) >= std::fabs(radial.z) ? 1 : 2);
                double length = 0.0;
                for (int a = 0; a < samples; ++a)
                    for (int b = 0; b < samples; ++b) {
                        Vec3 lo = c - Vec3(0.5, 0.5, 0.5), hi;
                        lo[(axis + 1) % 3] += (a + 0.5) / samples;
                        lo[(axis + 2) % 3] += (b + 0.5) / samples;
                        hi = lo;
                        hi[axis] += 1.0;
                        const bool inLo = ionised(lo), inHi = ionised(hi);
                        if (inLo == inHi) {
                            length += inLo ? 1.0 : 0.0;
                            continue;
                        }
                        double t0 = 0.0, t1 = 1.0; // ionised(t0) == inLo
                        for (int it = 0; it < 30; ++it) {
                            const double t = 0.5 * (t0 + t1);
                            Vec3 m = lo;
                            m[axis] += t;
                            (ionised(m) == inLo ? t0 : t1) = t;
                        }
                        length += inLo ? t0 : 1.0 - t0;
                    }
                out[density.index(i, j, k)] = float(length / (samples * samples));
            }
    return out;
}

} // namespace nebula
