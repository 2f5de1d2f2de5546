#pragma once
/// @file dust.h
/// Dust model (DESIGN §3): extinction curve, phase functions, and the parameters that
/// travel with the grids as the file metadata `nebula:dust`.

#include <array>
#include <cmath>
#include <string>

namespace nebula {

constexpr double PI = 3.14159265358979323846;
constexpr double INV_FOUR_PI = 1.0 / (4.0 * PI);

/// Selectable single-scattering phase functions (DESIGN §3).
enum class PhaseModel { HenyeyGreenstein, Rayleigh, MieHazy, MieMurky };

/// "hg", "rayleigh", "hazy", "murky" <-> PhaseModel. Throws Error on an unknown name.
PhaseModel phaseModelFromString(const std::string& name);
std::string toString(PhaseModel model);

/// Henyey-Greenstein phase function [1/sr] (DESIGN §3). mu = cosine between the light's
/// travel direction and the direction to the eye; g > 0 scatters forward.
inline double henyeyGreenstein(double mu, double g)
{
    const double d = 1.0 + g * g - 2.0 * g * mu;
    return INV_FOUR_PI * (1.0 - g * g) / (d * std::sqrt(d));
}

/// Phase function p(mu) [1/sr] of @p model, normalised to unit integral over the sphere.
/// @p g is used by Henyey-Greenstein only.
double phaseFunction(PhaseModel model, double mu, double g);

/// Cardelli, Clayton & Mathis (1989) extinction curve A(lambda)/A_V for wavelength
/// @p lambda_nm [nm] and total-to-selective extinction @p R_V. Valid 0.3-8 um^-1, i.e.
/// 125-3333 nm (infrared, optical/NIR and the ultraviolet; the far-UV piece 8-10 um^-1 is
/// not implemented); throws Error outside, or if R_V is not a finite number > 0.
double ccmExtinction(double lambda_nm, double R_V);

/// Dust parameters shared by every stage (DESIGN §2-3).
struct DustParams
{
    double kappa_V = 1.5e-3;  ///< V-band extinction per n_H per length [pc^-1 cm^3]
    double albedo = 0.6;      ///< single-scattering albedo a [0, 1]
    double g = 0.6;           ///< Henyey-Greenstein asymmetry (-1, 1)
    PhaseModel phase = PhaseModel::HenyeyGreenstein;
    std::string curve = "CCM89";  ///< extinction curve name (only CCM89 for now)
    double R_V = 3.1;         ///< total-to-selective extinction A_V / E(B-V)

    /// Throws UsageError naming the offending parameter if any value is out of range.
    void validate() const;
    /// JSON object {"kappa_V", "albedo", "g", "phase", "curve", "R_V"}.
    std::string toJson() const;
    /// Parses toJson()'s format; @p source names the file for error messages. Every field is
    /// required; unknown fields are ignored. Throws Error (not UsageError: the values come
    /// from a file) on invalid JSON, a missing or mistyped field, an unknown phase name, or a
    /// value validate() rejects.
    static DustParams fromJson(const std::string& text, const std::string& source);
};

} // namespace nebula
