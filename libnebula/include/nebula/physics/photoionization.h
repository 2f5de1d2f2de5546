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
};

/// Parses "he=0.1,n=4e-5,o=3.3e-4,s=9e-6" (any of the four, in any order; the others keep
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

} // namespace nebula
