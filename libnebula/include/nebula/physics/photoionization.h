// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file photoionization.h
/// Photoionised gas (DESIGN §16): recombination coefficients, the ionising photon rates of a
/// star, and the emissivities of the nebular lines. Formulas and atomic data only; the
/// ionisation of a grid by its stars is physics/ionization.h.
///
/// Sources: Osterbrock & Ferland 2006, "Astrophysics of Gaseous Nebulae and Active Galactic
/// Nuclei" (2nd ed.; "AGN2"): Table 2.1 (hydrogen recombination), Table 2.4 (helium), Table 4.4
/// (Balmer emissivities), Tables 3.3-3.4 (collision strengths and transition probabilities);
/// Storey & Zeippen 2000 (MNRAS 312, 813) for the doublet ratios.

#include <string>
#include <vector>

namespace nebula {

/// Ionisation thresholds [eV]: H0 (13.6), He0 (24.6) and O+ (35.1, O+ -> O++).
inline constexpr double H_IONIZATION_EV = 13.598;
inline constexpr double HE_IONIZATION_EV = 24.587;
inline constexpr double OII_IONIZATION_EV = 35.121;

/// Case B recombination coefficient of hydrogen alpha_B(T) [cm^3 s^-1]: AGN2 Table 2.1
/// (4.54e-13 at 5000 K, 2.59e-13 at 10^4 K, 1.43e-13 at 20000 K), a power law in T between
/// the tabulated temperatures and beyond them. @p T [K] > 0.
double caseBRecombinationH(double T);

/// Case B recombination coefficient of He0 (He+ + e -> He0) [cm^3 s^-1]: AGN2 Table 2.4
/// (2.73e-13 at 10^4 K), scaled as (T / 10^4 K)^-0.79.
double caseBRecombinationHe(double T);

/// Charge exchange O++ + H0 -> O+ + H+ [cm^3 s^-1]: Kingdon & Ferland 1996 (ApJS 106, 205),
/// 1.04e-9 (T / 10^4 K)^0.0315 (1 - 0.61 exp(-9.73 T / 10^4 K)).
double chargeExchangeOIII(double T);

/// Total recombination coefficient of O++ -> O+ (radiative plus low-temperature dielectronic)
/// [cm^3 s^-1]: 2.0e-12 (T / 10^4 K)^-0.65 radiative (Aldrovandi & Pequignot 1973) plus
/// 1.0e-12 dielectronic at nebular temperatures (Nussbaumer & Storey 1983), an approximation.
double recombinationOIII(double T);

/// 4 pi j(H-beta) / (n_e n_p) [erg cm^3 s^-1], Case B at n_e = 100 cm^-3: AGN2 Table 4.4
/// (2.20e-25 at 5000 K, 1.24e-25 at 10^4 K, 6.59e-26 at 20000 K), power law between.
double hBetaEmissivity(double T);

/// The Case B energy ratio H-alpha / H-beta: AGN2 Table 4.4 (3.04 at 5000 K, 2.86 at 10^4 K,
/// 2.75 at 20000 K), power law between.
double balmerDecrement(double T);

/// Effective recombination coefficient of H-beta [cm^3 s^-1]: hBetaEmissivity / h nu(H-beta).
double hBetaEffectiveRecombination(double T);

/// The fraction of a black body's photons above @p thresholdEv [eV] at temperature @p T [K]:
/// integral over x > h nu0 / kT of x^2 / (e^x - 1), divided by 2 zeta(3) (the whole).
double blackbodyPhotonFraction(double T, double thresholdEv);

/// Photons per second above @p thresholdEv [eV] of a black body of bolometric luminosity
/// @p luminosity [L_sun] and temperature @p T [K].
double blackbodyPhotonRate(double luminosity, double T, double thresholdEv);

/// The photon-weighted mean hydrogen photoionisation cross-section [cm^2] of a black body's
/// photons above 13.6 eV, with sigma(nu) = 6.30e-18 (nu0 / nu)^3 cm^2 (AGN2 §2.1's hydrogenic
/// approximation): what the gas at an ionisation front sees.
double meanHydrogenCrossSection(double T);

/// A star's ionising photon rates [s^-1]: above 13.6 eV (Q(H0)), above 24.6 eV (He0) and
/// above 35.1 eV (O+ -> O++).
struct IonizingRates
{
    double h = 0.0;
    double he = 0.0;
    double oiii = 0.0;
};

/// The rates of a star of luminosity @p luminosity [L_sun] and temperature @p T [K]: a black
/// body's, or, when @p q > 0 [s^-1] is given, Q(H0) = q and the harder rates in the black
/// body's proportions; @p qOIII > 0 replaces the rate above 35.1 eV.
IonizingRates ionizingRates(double luminosity, double T, double q = 0.0, double qOIII = 0.0);

/// Number abundances relative to hydrogen. The defaults are the Lexington benchmark's H II
/// region abundances (Ferland 1995; Pequignot et al. 2001), close to Orion's gas phase.
struct Abundances
{
    double he = 0.1;
    double n = 4.0e-5;
    double o = 3.3e-4;
    double s = 9.0e-6;
    double ne = 5.0e-5; ///< neon: only its [Ne II] 12.8 um cooling
};

/// Parses "he=0.1,n=4e-5,o=3.3e-4,ne=5e-5,s=9e-6" (any of the five, in any order; the others keep
/// @p base's values): numbers >= 0 and at most 1. Throws Error starting with @p source naming
/// the item otherwise.
Abundances parseAbundances(const std::string& text, const std::string& source,
                           Abundances base = {});

/// A collisionally excited (forbidden) line pair from one upper term (or two upper levels),
/// in the two-level approximation with collisional de-excitation: emissivity per ion and
/// electron `q_12 h nu / (1 + n_e / n_c)`, q_12 = 8.629e-6 Omega / (g_1 sqrt(T))
/// exp(-E / kT), n_c = A / q_21.
struct ForbiddenLevel
{
    const char* line;   ///< the catalogue name of the line (physics/lines.h)
    double wavelength;  ///< [nm] in air
    double omega;       ///< collision strength from the ground term (at 10^4 K)
    double gLower;      ///< statistical weight of the ground term
    double gUpper;      ///< statistical weight of the upper level
    double energyK;     ///< upper level's energy over k [K]
    double einsteinA;   ///< this line's transition probability [s^-1]
    double einsteinSum; ///< the upper level's total transition probability [s^-1]
};

/// The forbidden lines nebula makes (AGN2 Tables 3.3-3.4 at 10^4 K; doublet ratios of Storey
/// & Zeippen 2000): [O III] 5007, 4959; [N II] 6583, 6548; [S II] 6716, 6731; [O I] 6300, 6363.
const std::vector<ForbiddenLevel>& oiiiLevels();
const std::vector<ForbiddenLevel>& niiLevels();
const std::vector<ForbiddenLevel>& siiLevels();
const std::vector<ForbiddenLevel>& oiLevels();

/// 4 pi j / (n_e n_ion) [erg cm^3 s^-1] of one forbidden line at electron temperature @p T [K]
/// and density @p ne [cm^-3].
double forbiddenEmissivity(const ForbiddenLevel& level, double T, double ne);

/// The lines of a level list as a line list "NAME:STRENGTH,..." (physics/lines.h) with the
/// strengths in proportion to their emissivities at @p T and @p ne, the strongest 1.
std::string forbiddenLineList(const std::vector<ForbiddenLevel>& levels, double T, double ne);

/// The sum of the levels' emissivities [erg cm^3 s^-1].
double forbiddenEmissivitySum(const std::vector<ForbiddenLevel>& levels, double T, double ne);

/// Photoionisation cross-section [cm^2] in the power-law form AGN2 §2.4 uses for He and the
/// heavy elements (the fits of Henry 1970): a_T [beta (nu_T / nu)^s + (1 - beta) (nu_T /
/// nu)^(s + 1)] above the threshold nu_T, 0 below.
struct CrossSectionFit
{
    double thresholdEv;
    double aT; ///< at the threshold [cm^2]
    double beta;
    double s;
    double at(double ev) const;
};
/// He0 (24.6 eV: a_T 7.83e-18 cm^2, beta 1.66, s 2.05) and O+ (35.1 eV: 7.32e-18, 3.84, 2.0).
inline constexpr CrossSectionFit HE0_CROSS_SECTION{HE_IONIZATION_EV, 7.83e-18, 1.66, 2.05};
inline constexpr CrossSectionFit OII_CROSS_SECTION{OII_IONIZATION_EV, 7.32e-18, 3.84, 2.0};

/// A black body's photons split in bands, the photon-weighted mean cross-sections [cm^2] of
/// each band's absorbers, and the mean excess energies [erg] its photons leave as heat.
struct BandCrossSections
{
    double hAll = 0.0;   ///< H0, photons above 13.6 eV (meanHydrogenCrossSection)
    double hHard = 0.0;  ///< H0, photons above 35.1 eV
    double heSoft = 0.0; ///< He0, photons from 24.6 to 35.1 eV
    double heHard = 0.0; ///< He0, photons above 35.1 eV
    double oHard = 0.0;  ///< O+, photons above 35.1 eV
};
BandCrossSections bandCrossSections(double T);

/// The heat a photoionisation leaves [erg]: the mean excess energy (h nu - threshold) of a
/// black body's photons from 13.6 to 24.6 eV (absorbed by H) and above 24.6 eV (by He0). A
/// documented approximation: the star's spectrum as emitted, not hardened along the ray.
struct PhotoHeating
{
    double h = 0.0;
    double he = 0.0;
};
PhotoHeating blackbodyHeating(double T);

/// The ionised gas of a voxel as the thermal balance sees it: n_H [cm^-3], He+/He (S++/S
/// follows it, S+ the rest) and O++/O (N++/N follows it; O+ and N+ the rest); H is wholly
/// ionised, Ne is Ne+. n_e = n_H (1 + He abundance x He+/He).
struct IonisedGas
{
    double nH = 0.0;
    double heii = 0.0;
    double oiii = 0.0;
};

/// The ions whose collisionally excited lines cool the gas.
enum class CoolingIon { OIII, OII, NII, NIII, NeII, SII, SIII };

/// One collisionally excited transition from the ground level (or term) in the two-level
/// approximation: cooling per ion and electron q_12 k E / (1 + n_e / n_c), q_12 = 8.629e-6
/// Omega / (g_1 sqrt(T)) exp(-E / kT), n_c = A / q_21 (AGN2 eq. 3.20-3.31).
struct CoolingTransition
{
    const char* name; ///< e.g. "[O III] 88 um"
    CoolingIon ion;
    double omega;     ///< collision strength (at 10^4 K)
    double gLower;    ///< statistical weight of the lower level (term)
    double gUpper;    ///< of the upper level
    double energyK;   ///< upper level's energy over k [K]
    double einsteinA; ///< the upper level's total transition probability [s^-1]
};

/// The transitions of the thermal balance: [O III] 88/52 um and 4959/5007, [O II] 3726/3729,
/// [N II] 205/122 um and 6548/6583, [N III] 57 um, [Ne II] 12.8 um, [S II] 6716/6731, [S III]
/// 33/18.7 um and 9069/9531. Sources in photoionization.cpp.
const std::vector<CoolingTransition>& coolingTransitions();

/// Cooling per ion and electron [erg cm^3 s^-1] of one transition at @p T [K], @p ne [cm^-3].
double transitionCooling(const CoolingTransition& t, double T, double ne);

/// The cooling of the ionised gas [erg cm^-3 s^-1] at @p T [K]: its lines, Case B recombination
/// (H and He: n_e n_+ alpha_B k T (0.684 - 0.0416 ln(T / 10^4 K)), Draine 2011 eq. 27.23) and
/// free-free (1.42e-27 g_ff sqrt(T) n_e n_+, g_ff = 1.3, AGN2 eq. 3.15).
double coolingRate(double T, const IonisedGas& gas, const Abundances& ab);

/// The photoheating [erg cm^-3 s^-1] at @p T: every recombination (alpha_B of H, of He)
/// balanced by a photoionisation that leaves @p heat, except that as many H photoionisations
/// as He recombinations are by the He I recombination photons (0.96 of them, 6.3 eV above
/// 13.6 eV on average; AGN2 §2.4).
double heatingRate(double T, const IonisedGas& gas, const Abundances& ab, const PhotoHeating& heat);

/// The electron temperature [K] where heatingRate equals coolingRate, by bisection in log T
/// over 1000 .. 10^5 K (the ends where the balance lies outside).
double thermalBalanceTemperature(const IonisedGas& gas, const Abundances& ab,
                                 const PhotoHeating& heat);

} // namespace nebula
