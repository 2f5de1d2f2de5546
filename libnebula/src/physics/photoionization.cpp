// SPDX-License-Identifier: Apache-2.0
/// @file photoionization.cpp
/// Recombination, ionising photon rates and nebular line emissivities: see photoionization.h.

#include "nebula/physics/photoionization.h"

#include "nebula/core/error.h"
#include "nebula/core/units.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace nebula {

namespace {

/// hc [erg nm]; the lines' energies use vacuum wavelengths (air times 1.00028).
constexpr double HC_ERG_NM = 1.98644586e-9;
constexpr double AIR_TO_VACUUM = 1.00028;
/// kT [eV] per K.
constexpr double K_EV = 8.617333262e-5;
/// k [erg K^-1] and the electronvolt [erg].
constexpr double K_BOLTZMANN_ERG = BOLTZMANN_K * 1e7;
constexpr double EV_ERG = 1.602176634e-12;
/// He I recombination photons that ionise H on the spot, per He recombination, and their mean
/// energy above 13.6 eV [eV]: about 3/4 of the recombinations end in 2 3S (19.8 eV), the
/// rest mostly 21.2 eV and two-photon decays (AGN2 §2.4).
constexpr double HE_DIFFUSE_FRACTION = 0.96;
constexpr double HE_DIFFUSE_EXCESS_EV = 6.3;
/// The collision rate constant of q_12 = 8.629e-6 Omega / (g sqrt(T)) [cm^3 s^-1 K^1/2].
constexpr double COLLISION_CONSTANT = 8.629e-6;

/// Throws Error unless @p T [K] is finite and > 0.
void requireTemperature(double T)
{
    if (!(T > 0.0) || !std::isfinite(T)) {
        throw Error("photoionisation: temperature must be finite and > 0 [K], got " +
                    std::to_string(T));
    }
}

/// A quantity tabulated at 5000, 10^4 and 20000 K, a power law in T through the nearest pair
/// (and beyond the ends).
double powerLawTable(double T, double v5000, double v10000, double v20000)
{
    requireTemperature(T);
    const bool low = T < 1e4;
    const double a = low ? v5000 : v10000, b = low ? v10000 : v20000;
    const double t0 = low ? 5000.0 : 1e4;
    const double slope = std::log(b / a) / std::log(2.0);
    return a * std::pow(T / t0, slope);
}

double photonEnergyErg(double airNm)
{
    return HC_ERG_NM / (airNm * AIR_TO_VACUUM);
}

/// integral_x0^inf x^2 / (e^x - 1) dx = sum_k e^{-k x0} (x0^2/k + 2 x0/k^2 + 2/k^3).
double planckPhotonTail(double x0)
{
    if (x0 <= 0.0) return 2.0 * 1.2020569031595942;
    double sum = 0.0;
    for (int k = 1; k < 200; ++k) {
        const double kd = k;
        const double term =
            std::exp(-kd * x0) * (x0 * x0 / kd + 2.0 * x0 / (kd * kd) + 2.0 / (kd * kd * kd));
        sum += term;
        if (term < 1e-17 * sum) break;
    }
    return sum;
}

} // namespace

double caseBRecombinationH(double T)
{
    return powerLawTable(T, 4.54e-13, 2.59e-13, 1.43e-13);
}

double caseBRecombinationHe(double T)
{
    requireTemperature(T);
    return 2.73e-13 * std::pow(T / 1e4, -0.79);
}

double chargeExchangeOIII(double T)
{
    requireTemperature(T);
    const double t4 = T / 1e4;
    return 1.04e-9 * std::pow(t4, 0.0315) * (1.0 - 0.61 * std::exp(-9.73 * t4));
}

double recombinationOIII(double T)
{
    requireTemperature(T);
    return 2.0e-12 * std::pow(T / 1e4, -0.65) + 1.0e-12;
}

double hBetaEmissivity(double T)
{
    return powerLawTable(T, 2.20e-25, 1.24e-25, 6.59e-26);
}

double balmerDecrement(double T)
{
    return powerLawTable(T, 3.04, 2.86, 2.75);
}

double hBetaEffectiveRecombination(double T)
{
    return hBetaEmissivity(T) / photonEnergyErg(486.13);
}

double blackbodyPhotonFraction(double T, double thresholdEv)
{
    return planckPhotonTail(thresholdEv / (K_EV * T)) / (2.0 * 1.2020569031595942);
}

double blackbodyPhotonRate(double luminosity, double T, double thresholdEv)
{
    // N(>x0) = L / kT * 15 / pi^4 * integral_x0 x^2 / (e^x - 1) dx.
    const double kT = K_EV * T * 1.602176634e-12; // [erg]
    return luminosity * L_SUN_CGS / kT * 15.0 / std::pow(PI, 4) *
           planckPhotonTail(thresholdEv / (K_EV * T));
}

double meanHydrogenCrossSection(double T)
{
    // Photon-weighted mean of 6.3e-18 (x0/x)^3 over x^2 / (e^x - 1), x > x0: Simpson's rule
    // over x0 .. x0 + 40 (the rest is below 1e-17).
    const double x0 = H_IONIZATION_EV / (K_EV * T);
    const int n = 4000;
    const double h = 40.0 / n;
    double num = 0.0, den = 0.0;
    for (int i = 0; i <= n; ++i) {
        const double x = x0 + h * i;
        const double w = (i == 0 || i == n) ? 1.0 : (i % 2 ? 4.0 : 2.0);
        const double photons = x * x / std::expm1(x);
        den += w * photons;
        num += w * photons * std::pow(x0 / x, 3.0);
    }
    return 6.30e-18 * num / den;
}

IonizingRates ionizingRates(double luminosity, double T, double q, double qOIII)
{
    IonizingRates r;
    r.h = blackbodyPhotonRate(luminosity, T, H_IONIZATION_EV);
    r.he = blackbodyPhotonRate(luminosity, T, HE_IONIZATION_EV);
    r.oiii = blackbodyPhotonRate(luminosity, T, OII_IONIZATION_EV);
    if (q > 0.0) {
        const double scale = r.h > 0.0 ? q / r.h : 0.0;
        r.he *= scale;
        r.oiii *= scale;
        r.h = q;
    }
    if (qOIII > 0.0) r.oiii = qOIII;
    return r;
}

Abundances parseAbundances(const std::string& text, const std::string& source, Abundances base)
{
    std::size_t start = 0;
    while (start <= text.size()) {
        const std::size_t end = std::min(text.find(',', start), text.size());
        const std::string item = text.substr(start, end - start);
        const std::size_t eq = item.find('=');
        const std::string key = item.substr(0, eq);
        double* field = key == "he"   ? &base.he
                        : key == "n"  ? &base.n
                        : key == "o"  ? &base.o
                        : key == "s"  ? &base.s
                        : key == "ne" ? &base.ne
                                      : nullptr;
        if (eq == std::string::npos || !field) {
            throw Error(source + ": \"" + item +
                        "\": expected ELEMENT=VALUE with ELEMENT he, n, o, ne or s "
                        "(number abundances relative to H), e.g. he=0.1,o=3.3e-4");
        }
        char* stop = nullptr;
        const std::string value = item.substr(eq + 1);
        const double v = std::strtod(value.c_str(), &stop);
        if (value.empty() || *stop != '\0' || !(v >= 0.0) || !(v <= 1.0)) {
            throw Error(source + ": \"" + item + "\": the abundance must be a number from 0 to 1");
        }
        *field = v;
        start = end + 1;
    }
    return base;
}

namespace {

// Energies over k from the levels' term values [cm^-1] times hc/k = 1.438777 cm K.
const std::vector<ForbiddenLevel> OIII = {
    {"[O III]5007", 500.684, 2.29, 9, 5, 20273.27 * 1.438777, 1.960e-2, 2.617e-2},
    {"[O III]4959", 495.891, 2.29, 9, 5, 20273.27 * 1.438777, 6.520e-3, 2.617e-2},
};
const std::vector<ForbiddenLevel> NII = {
    {"[N II]6583", 658.345, 2.64, 9, 5, 15316.2 * 1.438777, 2.920e-3, 3.904e-3},
    {"[N II]6548", 654.805, 2.64, 9, 5, 15316.2 * 1.438777, 9.840e-4, 3.904e-3},
};
const std::vector<ForbiddenLevel> SII = {
    {"[S II]6716", 671.644, 4.14, 4, 6, 14884.7 * 1.438777, 2.60e-4, 2.60e-4},
    {"[S II]6731", 673.082, 2.76, 4, 4, 14852.9 * 1.438777, 8.82e-4, 8.82e-4},
};
const std::vector<ForbiddenLevel> OI = {
    {"[O I]6300", 630.030, 0.266, 9, 5, 15867.86 * 1.438777, 5.63e-3, 7.45e-3},
    {"[O I]6363", 636.378, 0.266, 9, 5, 15867.86 * 1.438777, 1.82e-3, 7.45e-3},
};

} // namespace

const std::vector<ForbiddenLevel>& oiiiLevels()
{
    return OIII;
}
const std::vector<ForbiddenLevel>& niiLevels()
{
    return NII;
}
const std::vector<ForbiddenLevel>& siiLevels()
{
    return SII;
}
const std::vector<ForbiddenLevel>& oiLevels()
{
    return OI;
}

double forbiddenEmissivity(const ForbiddenLevel& level, double T, double ne)
{
    requireTemperature(T);
    const double rootT = std::sqrt(T);
    const double q12 =
        COLLISION_CONSTANT * level.omega / (level.gLower * rootT) * std::exp(-level.energyK / T);
    const double q21 = COLLISION_CONSTANT * level.omega / (level.gUpper * rootT);
    const double nc = level.einsteinSum / q21;
    const double branching = level.einsteinA / level.einsteinSum;
    return q12 * branching * photonEnergyErg(level.wavelength) / (1.0 + std::max(ne, 0.0) / nc);
}

double forbiddenEmissivitySum(const std::vector<ForbiddenLevel>& levels, double T, double ne)
{
    double sum = 0.0;
    for (const auto& l : levels)
        sum += forbiddenEmissivity(l, T, ne);
    return sum;
}

std::string forbiddenLineList(const std::vector<ForbiddenLevel>& levels, double T, double ne)
{
    double strongest = 0.0;
    for (const auto& l : levels)
        strongest = std::max(strongest, forbiddenEmissivity(l, T, ne));
    std::string out;
    for (const auto& l : levels) {
        char buf[64];
        std::snprintf(buf, sizeof buf, "%.4g", forbiddenEmissivity(l, T, ne) / strongest);
        out += (out.empty() ? "" : ",") + std::string(l.line) + ":" + buf;
    }
    return out;
}

double CrossSectionFit::at(double ev) const
{
    if (ev < thresholdEv) return 0.0;
    const double x = thresholdEv / ev;
    return aT * (beta * std::pow(x, s) + (1.0 - beta) * std::pow(x, s + 1.0));
}

namespace {

/// Photon-weighted means over a black body's photons x = h nu / kT in [x0, x1] (x1 <= 0: to
/// x0 + 40, where the rest is below 1e-17) of f(photon energy [eV]), by Simpson's rule.
template <class F> double blackbodyMean(double T, double e0, double e1, F&& f)
{
    const double kT = K_EV * T, x0 = e0 / kT, x1 = e1 > 0.0 ? e1 / kT : x0 + 40.0;
    const int n = 4000;
    const double h = (x1 - x0) / n;
    double num = 0.0, den = 0.0;
    for (int i = 0; i <= n; ++i) {
        const double x = x0 + h * i;
        const double w = ((i == 0 || i == n) ? 1.0 : (i % 2 ? 4.0 : 2.0)) * x * x / std::expm1(x);
        den += w;
        num += w * f(x * kT);
    }
    return num / den;
}

} // namespace

BandCrossSections bandCrossSections(double T)
{
    requireTemperature(T);
    const auto hydrogen = [](double ev) { return 6.30e-18 * std::pow(H_IONIZATION_EV / ev, 3.0); };
    const auto helium = [](double ev) { return HE0_CROSS_SECTION.at(ev); };
    BandCrossSections b;
    b.hAll = meanHydrogenCrossSection(T);
    b.hHard = blackbodyMean(T, OII_IONIZATION_EV, 0.0, hydrogen);
    b.heSoft = blackbodyMean(T, HE_IONIZATION_EV, OII_IONIZATION_EV, helium);
    b.heHard = blackbodyMean(T, OII_IONIZATION_EV, 0.0, helium);
    b.oHard = blackbodyMean(T, OII_IONIZATION_EV, 0.0,
                            [](double ev) { return OII_CROSS_SECTION.at(ev); });
    return b;
}

PhotoHeating blackbodyHeating(double T)
{
    requireTemperature(T);
    const auto energy = [](double ev) { return ev; };
    PhotoHeating h;
    h.h = (blackbodyMean(T, H_IONIZATION_EV, HE_IONIZATION_EV, energy) - H_IONIZATION_EV) * EV_ERG;
    h.he = (blackbodyMean(T, HE_IONIZATION_EV, 0.0, energy) - HE_IONIZATION_EV) * EV_ERG;
    return h;
}

namespace {

constexpr double CM_TO_K = 1.438777; ///< hc / k [cm K]: a term value [cm^-1] over k [K]

// Collision strengths at 10^4 K and transition probabilities: AGN2 Tables 3.3-3.5 ([O III],
// [O II], [N II], [S II], [Ne II]); [S III] from Hudson, Ramsbottom & Scott 2012 (ApJ 750, 65;
// 1D2 the sum over the 3P levels), [N III] 57 um from Blum & Pradhan 1992 (ApJS 80, 425). A
// fine-structure level is excited from the ground level (population in it neglected); an
// optical term from the whole ground term (g of the term).
const std::vector<CoolingTransition> COOLING = {
    {"[O III] 88 um", CoolingIon::OIII, 0.55, 1, 3, 113.2 * CM_TO_K, 2.62e-5},
    {"[O III] 52 um", CoolingIon::OIII, 0.27, 1, 5, 306.2 * CM_TO_K, 9.76e-5},
    {"[O III] 4959/5007", CoolingIon::OIII, 2.29, 9, 5, 20273.27 * CM_TO_K, 2.617e-2},
    {"[O II] 3729", CoolingIon::OII, 0.80, 4, 6, 26810.55 * CM_TO_K, 3.6e-5},
    {"[O II] 3726", CoolingIon::OII, 0.54, 4, 4, 26830.57 * CM_TO_K, 1.6e-4},
    {"[N II] 205 um", CoolingIon::NII, 0.41, 1, 3, 48.7 * CM_TO_K, 2.08e-6},
    {"[N II] 122 um", CoolingIon::NII, 0.27, 1, 5, 130.8 * CM_TO_K, 7.46e-6},
    {"[N II] 6548/6583", CoolingIon::NII, 2.64, 9, 5, 15316.2 * CM_TO_K, 3.904e-3},
    {"[N III] 57 um", CoolingIon::NIII, 1.45, 2, 4, 174.4 * CM_TO_K, 4.77e-5},
    {"[Ne II] 12.8 um", CoolingIon::NeII, 0.30, 4, 2, 780.4 * CM_TO_K, 8.59e-3},
    {"[S II] 6716", CoolingIon::SII, 4.14, 4, 6, 14884.7 * CM_TO_K, 2.60e-4},
    {"[S II] 6731", CoolingIon::SII, 2.76, 4, 4, 14852.9 * CM_TO_K, 8.82e-4},
    {"[S III] 33 um", CoolingIon::SIII, 2.26, 1, 3, 298.7 * CM_TO_K, 4.72e-4},
    {"[S III] 18.7 um", CoolingIon::SIII, 1.02, 1, 5, 833.1 * CM_TO_K, 2.07e-3},
    {"[S III] 9069/9531", CoolingIon::SIII, 6.92, 9, 5, 11322.7 * CM_TO_K, 7.7e-2},
};

/// The ion's abundance relative to H in @p gas.
double ionAbundance(CoolingIon ion, const IonisedGas& gas, const Abundances& ab)
{
    const double oiii = std::clamp(gas.oiii, 0.0, 1.0), heii = std::clamp(gas.heii, 0.0, 1.0);
    switch (ion) {
    case CoolingIon::OIII: return ab.o * oiii;
    case CoolingIon::OII: return ab.o * (1.0 - oiii);
    case CoolingIon::NII: return ab.n * (1.0 - oiii);
    case CoolingIon::NIII: return ab.n * oiii;
    case CoolingIon::NeII: return ab.ne;
    case CoolingIon::SII: return ab.s * (1.0 - heii);
    case CoolingIon::SIII: return ab.s * heii;
    }
    return 0.0;
}

double electronDensity(const IonisedGas& gas, const Abundances& ab)
{
    return gas.nH * (1.0 + ab.he * std::clamp(gas.heii, 0.0, 1.0));
}

} // namespace

const std::vector<CoolingTransition>& coolingTransitions()
{
    return COOLING;
}

double transitionCooling(const CoolingTransition& t, double T, double ne)
{
    requireTemperature(T);
    const double rootT = std::sqrt(T);
    const double q12 = COLLISION_CONSTANT * t.omega / (t.gLower * rootT) * std::exp(-t.energyK / T);
    const double q21 = COLLISION_CONSTANT * t.omega / (t.gUpper * rootT);
    const double nc = t.einsteinA / q21;
    return q12 * K_BOLTZMANN_ERG * t.energyK / (1.0 + std::max(ne, 0.0) / nc);
}

double coolingRate(double T, const IonisedGas& gas, const Abundances& ab)
{
    const double ne = electronDensity(gas, ab);
    double lines = 0.0;
    for (const auto& t : COOLING)
        lines += ionAbundance(t.ion, gas, ab) * transitionCooling(t, T, ne);
    const double heii = ab.he * std::clamp(gas.heii, 0.0, 1.0);
    const double beta = 0.684 - 0.0416 * std::log(T / 1e4);
    const double recombination =
        K_BOLTZMANN_ERG * T * beta * (caseBRecombinationH(T) + heii * caseBRecombinationHe(T));
    const double freeFree = 1.42e-27 * 1.3 * std::sqrt(T) * (1.0 + heii);
    return ne * gas.nH * (lines + recombination + freeFree);
}

double heatingRate(double T, const IonisedGas& gas, const Abundances& ab, const PhotoHeating& heat)
{
    const double ne = electronDensity(gas, ab);
    const double heii = ab.he * std::clamp(gas.heii, 0.0, 1.0);
    // Of the H photoionisations, as many as He recombines are by the He I recombination
    // photons (19.8 eV from 2 3S, 21.2 eV from 2 1P, 2 1S's two photons; AGN2 §2.4): 0.96 of
    // them ionise H, leaving 6.3 eV on average instead of the star's heat.h.
    const double diffuse = HE_DIFFUSE_FRACTION * (HE_DIFFUSE_EXCESS_EV * EV_ERG - heat.h);
    return ne * gas.nH *
           (caseBRecombinationH(T) * heat.h + heii * caseBRecombinationHe(T) * (heat.he + diffuse));
}

double thermalBalanceTemperature(const IonisedGas& gas, const Abundances& ab,
                                 const PhotoHeating& heat)
{
    double lo = std::log(1000.0), hi = std::log(1e5);
    const auto excess = [&](double lnT) {
        const double T = std::exp(lnT);
        return heatingRate(T, gas, ab, heat) - coolingRate(T, gas, ab);
    };
    if (excess(lo) <= 0.0) return std::exp(lo);
    if (excess(hi) >= 0.0) return std::exp(hi);
    for (int i = 0; i < 40; ++i) { // to 1e-10 in ln T
        const double mid = 0.5 * (lo + hi);
        (excess(mid) > 0.0 ? lo : hi) = mid;
    }
    return std::exp(0.5 * (lo + hi));
}

} // namespace nebula
