// SPDX-License-Identifier: Apache-2.0
/// @file dust.cpp
/// Dust model (DESIGN §3): phase functions, the CCM89 extinction curve, and the
/// `nebula:dust` parameters with their JSON form.

#include "nebula/physics/dust.h"

#include "nebula/core/format.h"

#include "nebula/core/error.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdlib>
#include <sstream>
#include <string>

namespace nebula {

namespace {

using detail::numberText;

/// Hazy Mie approximation (Nishita et al.; DESIGN §3) [1/sr]:
/// p = 1/(4 pi) * (1/2 + 9/2 ((1 + mu)/2)^8). Unit integral over the sphere as written,
/// since 2 pi * int_{-1}^{1} ((1 + mu)/2)^n dmu / (4 pi) = 1/(n + 1): 1/2 + 9/2 * 1/9 = 1.
double mieHazy(double mu)
{
    const double h = 0.5 * (1.0 + mu);
    const double h2 = h * h;
    const double h4 = h2 * h2;
    return INV_FOUR_PI * (0.5 + 4.5 * h4 * h4);
}

/// Murky Mie approximation (Nishita et al.; DESIGN §3) [1/sr]:
/// p = 1/(4 pi) * (1/2 + 33/2 ((1 + mu)/2)^32). Unit integral as written: 1/2 + 33/2 * 1/33.
double mieMurky(double mu)
{
    double h = 0.5 * (1.0 + mu);
    for (int i = 0; i < 5; ++i) {
        h *= h; // h^(2^5) = h^32
    }
    return INV_FOUR_PI * (0.5 + 16.5 * h);
}

/// Rayleigh phase function 3/(16 pi) (1 + mu^2) [1/sr].
double rayleigh(double mu)
{
    return 3.0 / (16.0 * PI) * (1.0 + mu * mu);
}

/// Henyey-Greenstein scattering cosine from u in [0, 1) (textbook sign: g > 0 forward).
/// The inverse CDF mu = (1 + g^2 - ((1 - g^2)/(1 - g + 2 g u))^2) / (2 g), multiplied out in
/// v = 2u - 1 so that the 1/g cancels: exact for every g in (-1, 1) with no isotropic special
/// case near g = 0 (where the textbook form loses digits), and mu = v at g = 0.
double sampleHenyeyGreensteinCosine(double g, double u)
{
    const double v = 2.0 * u - 1.0;
    const double d = 1.0 + g * v;
    return (v + g * (0.5 * (3.0 + v * v) + g * (v + 0.5 * g * (v * v - 1.0)))) / (d * d);
}

/// Rayleigh scattering cosine from u in [0, 1). The CDF (mu^3 + 3 mu + 4)/8 = u is the
/// depressed cubic mu^3 + 3 mu - 2z = 0 with z = 4u - 2, whose single real root (Cardano)
/// cbrt(z + sqrt(z^2 + 1)) - cbrt(sqrt(z^2 + 1) - z) equals 2 sinh(asinh(z)/3) by the
/// triple-angle formula sinh 3x = 3 sinh x + 4 sinh^3 x; that form has no cancellation at z = 0.
double sampleRayleighCosine(double u)
{
    return 2.0 * std::sinh(std::asinh(4.0 * u - 2.0) / 3.0);
}

/// Hazy (n = 8) or murky (n = 32) Mie scattering cosine from u in [0, 1). With
/// h = (1 + mu)/2 the density 2 pi p(mu) = 1/4 + (n+1)/4 h^n is the exact mixture
/// 1/2 * isotropic (1/2) + 1/2 * power term ((n+1)/2 h^n), whose CDF in h is h^(n+1).
/// u < 1/2 picks the isotropic half and is rescaled to 2u, otherwise 2u - 1 (both exact in
/// double): exact in distribution, though not monotonic in u.
double sampleMieCosine(double n, double u)
{
    if (u < 0.5) {
        return 4.0 * u - 1.0;
    }
    const double h = std::pow(2.0 * u - 1.0, 1.0 / (n + 1.0));
    return 2.0 * h - 1.0;
}

/// @p mu clamped to [-1, 1] (rounding in the samplers may step outside by an ulp or so).
double clampCosine(double mu)
{
    return std::fmin(1.0, std::fmax(-1.0, mu));
}

/// The JSON type of @p value in words, for error messages.
std::string typeName(const nlohmann::json& value)
{
    return value.is_number() ? "a number" : std::string("a ") + value.type_name();
}

/// Field @p key of @p object as a number; Error naming @p source and the field otherwise.
double numberField(const nlohmann::json& object, const char* key, const std::string& source,
                   double fallback, std::vector<std::string>& missing)
{
    const auto it = object.find(key);
    if (it == object.end()) {
        missing.push_back(key);
        return fallback;
    }
    if (!it->is_number()) {
        throw Error(source + ": dust parameters: \"" + key + "\" must be a number, got " +
                    typeName(*it));
    }
    return it->get<double>();
}

/// Field @p key of @p object as a string; Error naming @p source and the field otherwise.
std::string stringField(const nlohmann::json& object, const char* key, const std::string& source,
                        const std::string& fallback, std::vector<std::string>& missing)
{
    const auto it = object.find(key);
    if (it == object.end()) {
        missing.push_back(key);
        return fallback;
    }
    if (!it->is_string()) {
        throw Error(source + ": dust parameters: \"" + key + "\" must be a string, got " +
                    typeName(*it));
    }
    return it->get<std::string>();
}

} // namespace

PhaseModel phaseModelFromString(const std::string& name)
{
    if (name == "hg") return PhaseModel::HenyeyGreenstein;
    if (name == "rayleigh") return PhaseModel::Rayleigh;
    if (name == "hazy") return PhaseModel::MieHazy;
    if (name == "murky") return PhaseModel::MieMurky;
    throw Error("unknown phase function \"" + name +
                "\", expected one of hg, rayleigh, hazy, murky");
}

std::string toString(PhaseModel model)
{
    switch (model) {
    case PhaseModel::HenyeyGreenstein: return "hg";
    case PhaseModel::Rayleigh: return "rayleigh";
    case PhaseModel::MieHazy: return "hazy";
    case PhaseModel::MieMurky: return "murky";
    }
    throw Error("unknown PhaseModel value " + std::to_string(static_cast<int>(model)));
}

double phaseFunction(PhaseModel model, double mu, double g)
{
    switch (model) {
    case PhaseModel::HenyeyGreenstein: return henyeyGreenstein(mu, g);
    case PhaseModel::Rayleigh: return rayleigh(mu);
    case PhaseModel::MieHazy: return mieHazy(mu);
    case PhaseModel::MieMurky: return mieMurky(mu);
    }
    throw Error("unknown PhaseModel value " + std::to_string(static_cast<int>(model)));
}

double samplePhaseCosine(PhaseModel model, double g, double u)
{
    switch (model) {
    case PhaseModel::HenyeyGreenstein: return clampCosine(sampleHenyeyGreensteinCosine(g, u));
    case PhaseModel::Rayleigh: return clampCosine(sampleRayleighCosine(u));
    case PhaseModel::MieHazy: return clampCosine(sampleMieCosine(8.0, u));
    case PhaseModel::MieMurky: return clampCosine(sampleMieCosine(32.0, u));
    }
    throw Error("unknown PhaseModel value " + std::to_string(static_cast<int>(model)));
}

double extinctionRatio(const DustParams& dust, double lambda_nm)
{
    return dust.curve == "grey" ? 1.0 : ccmExtinction(lambda_nm, dust.R_V);
}

double ccmExtinction(double lambda_nm, double R_V)
{
    // Cardelli, Clayton & Mathis 1989, ApJ 345, 245, eqs. 2-4: A/A_V = a(x) + b(x)/R_V with
    // x = 1/lambda [um^-1]. The far-UV piece (8-10 um^-1) is not implemented.
    const double x = 1000.0 / lambda_nm;
    if (!(x >= 0.3 && x <= 8.0)) {
        throw Error("CCM89 extinction: wavelength " + numberText(lambda_nm) +
                    " nm is outside the curve's range 125-3333 nm (0.3-8 um^-1)");
    }
    if (!(R_V > 0.0) || !std::isfinite(R_V)) {
        throw Error("CCM89 extinction: R_V must be a finite number > 0, got " + numberText(R_V));
    }

    double a = 0.0;
    double b = 0.0;
    if (x < 1.1) {
        // Infrared: power law.
        const double xp = std::pow(x, 1.61);
        a = 0.574 * xp;
        b = -0.527 * xp;
    } else if (x < 3.3) {
        // Optical / near infrared: 7th-degree polynomials in y = x - 1.82 (Horner form).
        const double y = x - 1.82;
        a = 1.0 + y * (0.17699 +
                       y * (-0.50447 +
                            y * (-0.02427 +
                                 y * (0.72085 + y * (0.01979 + y * (-0.77530 + y * 0.32999))))));
        b = y *
            (1.41338 +
             y * (2.28305 +
                  y * (1.07233 + y * (-5.38434 + y * (-0.62251 + y * (5.30260 + y * -2.09002))))));
    } else {
        // Ultraviolet: the 2175 A bump as a Drude-like term, plus the far-UV rise Fa, Fb
        // for x >= 5.9.
        double Fa = 0.0;
        double Fb = 0.0;
        if (x >= 5.9) {
            const double d = x - 5.9;
            Fa = -0.04473 * d * d - 0.009779 * d * d * d;
            Fb = 0.2130 * d * d + 0.1207 * d * d * d;
        }
        a = 1.752 - 0.316 * x - 0.104 / ((x - 4.67) * (x - 4.67) + 0.341) + Fa;
        b = -3.090 + 1.825 * x + 1.206 / ((x - 4.62) * (x - 4.62) + 0.263) + Fb;
    }
    return a + b / R_V;
}

void ScatteringMedium::validate() const
{
    if (!(albedo >= 0.0 && albedo <= 1.0)) {
        throw UsageError("albedo must be in [0, 1], got " + numberText(albedo));
    }
    if (!(std::abs(g) < 1.0)) {
        throw UsageError("g must satisfy |g| < 1, got " + numberText(g));
    }
}

double ScatteringMedium::phaseFunction(double mu) const
{
    return nebula::phaseFunction(phase, mu, g);
}

void DustParams::validate() const
{
    if (!(kappa_V > 0.0 && kappa_V <= MAX_KAPPA_V)) {
        throw UsageError("dust parameter kappa_V must be > 0 and at most " +
                         numberText(MAX_KAPPA_V) + " [pc^-1 cm^3] (Milky Way dust: 1.5e-3), got " +
                         numberText(kappa_V));
    }
    if (!(albedo >= 0.0 && albedo <= 1.0)) {
        throw UsageError("dust parameter albedo must be in [0, 1], got " + numberText(albedo));
    }
    if (!(std::fabs(g) < 1.0)) {
        throw UsageError("dust parameter g must be in (-1, 1), got " + numberText(g));
    }
    if (!(R_V >= MIN_R_V && R_V <= MAX_R_V)) {
        throw UsageError("dust parameter R_V must be in [" + numberText(MIN_R_V) + ", " +
                         numberText(MAX_R_V) + "] (Milky Way: 3.1; dense clouds up to 5.5), got " +
                         numberText(R_V));
    }
    if (curve != "CCM89" && curve != "grey") {
        throw UsageError("dust parameter curve must be \"CCM89\" or \"grey\", got \"" + curve +
                         "\"");
    }
    if (phase != PhaseModel::HenyeyGreenstein && phase != PhaseModel::Rayleigh &&
        phase != PhaseModel::MieHazy && phase != PhaseModel::MieMurky) {
        throw UsageError("dust parameter phase has an unknown value " +
                         std::to_string(static_cast<int>(phase)));
    }
}

std::string DustParams::toJson() const
{
    // nlohmann::json writes doubles with the fewest digits that read back exactly.
    const nlohmann::json j = {{"kappa_V", kappa_V},       {"albedo", albedo}, {"g", g},
                              {"phase", toString(phase)}, {"curve", curve},   {"R_V", R_V}};
    return j.dump();
}

DustParams DustParams::fromJson(const std::string& text, const std::string& source,
                                std::vector<std::string>* missingFields)
{
    const nlohmann::json j = detail::parseJson(text, source, "dust parameters: ");
    if (!j.is_object()) {
        throw Error(source + ": dust parameters: expected a JSON object, got " + typeName(j));
    }

    // A missing field takes the default (the same in every stage), and is reported.
    const DustParams defaults;
    DustParams params;
    std::vector<std::string> missing;
    params.kappa_V = numberField(j, "kappa_V", source, defaults.kappa_V, missing);
    params.albedo = numberField(j, "albedo", source, defaults.albedo, missing);
    params.g = numberField(j, "g", source, defaults.g, missing);
    const std::string phase = stringField(j, "phase", source, toString(defaults.phase), missing);
    try {
        params.phase = phaseModelFromString(phase);
    } catch (const Error& e) {
        throw Error(source + ": dust parameters: \"phase\": " + e.what());
    }
    params.curve = stringField(j, "curve", source, defaults.curve, missing);
    params.R_V = numberField(j, "R_V", source, defaults.R_V, missing);

    // Out-of-range values in a file are a data error, not a usage error.
    try {
        params.validate();
    } catch (const UsageError& e) {
        throw Error(source + ": " + e.what());
    }
    if (missingFields) *missingFields = std::move(missing);
    return params;
}

std::string DustParams::missingFieldsText(const std::vector<std::string>& missing) const
{
    std::string text;
    for (const auto& field : missing) {
        std::string value;
        if (field == "kappa_V") value = numberText(kappa_V);
        if (field == "albedo") value = numberText(albedo);
        if (field == "g") value = numberText(g);
        if (field == "phase") value = toString(phase);
        if (field == "curve") value = curve;
        if (field == "R_V") value = numberText(R_V);
        text += (text.empty() ? "" : ", ") + field + " = " + value;
    }
    return text;
}

} // namespace nebula
