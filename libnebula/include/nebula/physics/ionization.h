// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file ionization.h
/// Photoionisation equilibrium of a density field lit by stars (DESIGN §16): the ionisation
/// fronts along rays from every star, with Case B recombination (on the spot), the stars'
/// shares where their H II regions overlap, dust absorbing the ionising photons, and shadows.
///
/// Method (a Strömgren integral per direction with adaptive rays): from each star, rays leave
/// through the pixels of a cube map and split in four whenever their footprint grows wider than
/// `raySpacing` voxels (Abel & Wandelt 2002), so every voxel of the H II region is crossed by a
/// ray or two. A ray carries the star's photons per steradian, q = Q / 4 pi, and pays along
/// every voxel it crosses the recombinations of that stretch, alpha_B n_e n_p r^2 dr (exact
/// for the voxel's constant density: (r1^3 - r0^3) / 3), times the star's share of the
/// recombinations there; dust takes exp(-sigma_d n_H dr) of what is left. The front is where q
/// reaches 0, found inside its voxel in closed form: fronts are not stair-stepped. A voxel's H+
/// fraction is the part of the rays' volume in it (their tubes' r^2 dr dOmega) that lies in
/// front of the fronts, so a front voxel is partly ionised, and the grid's recombinations are
/// the ones the rays paid for.
///
/// Several stars: each point inside several stars' fronts shares its recombinations in
/// proportion to the stars' unattenuated fluxes Q / r^2 there; the fronts are iterated until
/// they stop moving, and at convergence the recombinations of the grid equal the photons the
/// stars spent on them. The He+ zone is the same march of the photons above 24.6 eV paying the
/// helium recombinations. The photons above 35.1 eV (O+ -> O++) are marched too: they pay their
/// share of the He0 photoionisations (in proportion to sigma_He q of the two He bands), of the
/// residual H0's (sigma_H q) and the O++ recombinations, so the O++ zone ends where they run
/// out; in each voxel O++/O is the local balance of O+ photoionisation by the marched hard
/// photons against radiative and dielectronic recombination and O++ + H0 charge exchange (the
/// H0 fraction from the local balance of H).
///
/// The electron temperature: a grid's (channel 1), else, with IonizationParams::thermalBalance,
/// the temperature where photoheating balances the cooling of the ionised gas (lines,
/// recombination, free-free: photoionization.h) at the voxel's n_e, He+/He and O++/O, from a
/// table built once per solve; else one value for the whole gas.

#include "nebula/core/run.h"
#include "nebula/physics/photoionization.h"
#include "nebula/volume/volume.h"

#include <string>
#include <vector>

namespace nebula {

/// A star as the ionisation sees it.
struct IonizingStar
{
    std::string name;
    Vec3 position;       ///< index space of the density volume
    IonizingRates rates; ///< [s^-1]
    double temperature;  ///< effective temperature [K] (the hardness of its photons)
};

/// The gas and the method's parameters.
struct IonizationParams
{
    double electronTemperature = 1e4; ///< T_e of the ionised gas [K]
    /// T_e from the thermal balance where the volume has no temperature (electronTemperature
    /// then only starts each ray's march)
    bool thermalBalance = false;
    double dustCrossSection = 0.0; ///< dust absorption per H atom of ionising photons [cm^2]
    Abundances abundances;         ///< He, N, O, S
    double voxelSizeCm = 0.0;      ///< edge of a (cubic) voxel [cm], > 0
    double raySpacing = 0.5;       ///< largest footprint of a ray before it splits [voxels]
    int maxIterations = 12;        ///< overlap iterations at most
    double tolerance = 1e-3;       ///< relative change of the ionised volume that stops them
};

/// What became of one star's ionising photons [s^-1], summed over its rays.
struct StarPhotons
{
    double emitted = 0.0;        ///< Q(H0)
    double recombined = 0.0;     ///< balanced recombinations in the grid
    double dust = 0.0;           ///< absorbed by dust
    double escaped = 0.0;        ///< left the grid
    double openSolidAngle = 0.0; ///< solid angle [sr] through which photons escape
};

/// The ionisation state of one voxel.
struct VoxelIonization
{
    double hii = 0.0;   ///< H+ / H: the voxel's volume fraction inside a front
    double heii = 0.0;  ///< He+ / He: the same for the He+ zone
    double oiii = 0.0;  ///< O++ / O
    double front = 0.0; ///< the volume fraction of the partly ionised layer at a front
    double ne = 0.0;    ///< mean electron density of the ionised part [cm^-3]
    double te = 0.0;    ///< electron temperature [K]
};

/// The solver. The density volume (channel 0: n_H [cm^-3], index space, cubic voxels; an
/// optional channel 1: the electron temperature [K], where > 0, else the thermal balance or
/// IonizationParams::electronTemperature) must outlive it.
class IonizationSolver
{
public:
    IonizationSolver(const SparseVolume& density, std::vector<IonizingStar> stars,
                     const IonizationParams& params);
    ~IonizationSolver();
    IonizationSolver(const IonizationSolver&) = delete;
    IonizationSolver& operator=(const IonizationSolver&) = delete;

    /// Marches every star's rays, iterating where H II regions overlap. @p run (may be null)
    /// shows progress and is asked to cancel.
    void solve(const Run* run = nullptr);

    /// The state of voxel (i, j, k) (index coordinates); thread-safe after solve().
    VoxelIonization at(int i, int j, int k) const;

    /// Per star, what its photons did (after solve()).
    const std::vector<StarPhotons>& photons() const { return mPhotons; }
    /// Overlap iterations solve() ran (1 when no H II regions overlap).
    int iterations() const { return mIterations; }
    /// The front's distance [voxels] from star @p s in direction @p d (index space); a very
    /// large value where photons escape.
    double frontDistance(std::size_t s, const Vec3& d) const;

    struct Maps;    ///< the cube maps of the fronts (implementation)
    struct Tally;   ///< per voxel, the rays' volume and its ionised parts (implementation)
    struct Thermal; ///< the thermal balance's table (implementation)

private:
    const SparseVolume& mDensity;
    std::vector<IonizingStar> mStars;
    IonizationParams mParams;
    std::vector<StarPhotons> mPhotons;
    std::vector<Maps*> mMaps;
    std::vector<Tally*> mTallies;
    std::vector<double> mFrontCrossSection; ///< per star, meanHydrogenCrossSection() [cm^2]
    Thermal* mThermal = nullptr;            ///< with thermalBalance
    int mIterations = 0;
};

/// Reference for tests (a few thousand voxels): the H+ fraction of every lattice point by the
/// definition, brute force: in each voxel whose corners disagree (the others are wholly
/// ionised or neutral), @p samples^2 lines along the axis nearest the star's direction, each
/// cut by bisection where its points stop being ionised; a point is ionised if the
/// recombinations alpha_B n_H^2 r^2 dr of the voxels on the straight line from the star to it
/// use up less than Q / 4 pi (a long characteristic per point). One star, no dust, no helium.
std::vector<float> ionizationReference(const SparseVolume& density, const IonizingStar& star,
                                       const IonizationParams& params, int samples);

} // namespace nebula
