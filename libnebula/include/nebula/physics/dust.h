// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file dust.h
/// Dust model (DESIGN §3): extinction curve, phase functions, and the parameters that
/// travel with the grids as the file metadata `nebula:dust`.

#include "nebula/core/units.h"

#include <array>
#include <cmath>
#include <string>
#include <vector>

namespace nebula {

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

/// Samples the scattering cosine mu of @p model (DESIGN §3-4) from @p u uniform in [0, 1):
/// the result is distributed on [-1, 1] with density 2 pi p(mu), p = phaseFunction(model, mu,
/// g). mu is the cosine between the incoming travel direction and the outgoing travel
/// direction (forward = +1), which is the same mu as in phaseFunction(): there the outgoing
/// direction is the direction to the eye. So g > 0 gives a mean mu of g > 0 (forward).
///  - Henyey-Greenstein: inverse CDF, textbook sign, rearranged so that it has no 1/g (exact
///    and stable as g -> 0; g = 0 gives the isotropic 2u - 1). @p g in (-1, 1).
///  - Rayleigh: exact inverse of the cubic CDF (mu^3 + 3 mu + 4)/8 (Cardano, in sinh form).
///  - hazy / murky Mie: exact mixture, 1/2 isotropic + 1/2 density (n+1)/2 ((1+mu)/2)^n with
///    n = 8 / 32, each by its closed-form inverse CDF; u picks the component and is then
///    rescaled to [0, 1). The result is exact in distribution but not monotonic in u.
/// @p g is used by Henyey-Greenstein only. The result is clamped to [-1, 1]. Throws Error on
/// an unknown @p model value.
double samplePhaseCosine(PhaseModel model, double g, double u);

/// Unit direction @p out at polar cosine @p mu and azimuth @p phi [rad] about the unit
/// direction @p in: out = sqrt(1 - mu^2) (cos phi b1 + sin phi b2) + mu in, with (b1, b2, in)
/// the orthonormal frame of Duff et al. 2017, "Building an Orthonormal Basis, Revisited"
/// (branchless, no singularity at in = -z). With in the incoming travel direction and mu from
/// samplePhaseCosine(), out is the outgoing travel direction. @p in must be unit length;
/// @p out may not alias @p in.
inline void sampleDirection(double mu, double phi, const double in[3], double out[3])
{
    // Frame (b1, b2) perpendicular to in (Duff et al. 2017, listing 3).
    const double sign = std::copysign(1.0, in[2]);
    const double a = -1.0 / (sign + in[2]);
    const double b = in[0] * in[1] * a;
    const double b1[3] = {1.0 + sign * in[0] * in[0] * a, sign * b, -sign * in[0]};
    const double b2[3] = {b, sign + in[1] * in[1] * a, -in[1]};

    const double sinTheta = std::sqrt(std::fmax(0.0, 1.0 - mu * mu));
    const double c = sinTheta * std::cos(phi);
    const double s = sinTheta * std::sin(phi);
    for (int i = 0; i < 3; ++i) {
        out[i] = c * b1[i] + s * b2[i] + mu * in[i];
    }
}

/// Cardelli, Clayton & Mathis (1989) extinction curve A(lambda)/A_V for wavelength
/// @p lambda_nm [nm] and total-to-selective extinction @p R_V. Valid 0.3-8 um^-1, i.e.
/// 125-3333 nm (infrared, optical/NIR and the ultraviolet; the far-UV piece 8-10 um^-1 is
/// not implemented); throws Error outside, or if R_V is not a finite number > 0.
double ccmExtinction(double lambda_nm, double R_V);

struct DustParams;
/// A(lambda)/A_V of @p dust's extinction curve at @p lambda_nm [nm] (see DustParams::curve).
double extinctionRatio(const DustParams& dust, double lambda_nm);

/// What one scattering event does: single-scattering albedo and phase function.
struct ScatteringMedium
{
    double albedo = 0.6;
    double g = 0.6; ///< Henyey-Greenstein asymmetry (used by PhaseModel::HenyeyGreenstein)
    PhaseModel phase = PhaseModel::HenyeyGreenstein;

    /// Throws UsageError unless albedo is in [0, 1] and |g| < 1.
    void validate() const;
    /// p(mu) [1/sr] of this medium (DESIGN §3).
    double phaseFunction(double mu) const;
};

/// The range of kappa_V [pc^-1 cm^3] DustParams::validate() accepts: Milky Way dust has
/// 1.5e-3; a billion times that still gives finite optical depths for any density a float grid
/// holds over any grid a float can place (each stage also checks its optical depths).
inline constexpr double MAX_KAPPA_V = 1e6;
/// The range of R_V (CCM89): measured sight lines lie within 2.1-5.6 (Fitzpatrick 1999); below 1
/// the curve's b(x)/R_V term runs away.
inline constexpr double MIN_R_V = 1.0;
inline constexpr double MAX_R_V = 10.0;

/// The dust of every stage (DESIGN §2-3): its scattering (the Monte Carlo medium, albedo a,
/// asymmetry g, phase model) plus its extinction: kappa_V and the curve A(lambda)/A_V. The
/// renderers extend it with their channels' extinction ratios (render/scene.h ChannelDust).
struct DustParams : ScatteringMedium
{
    double kappa_V = 1.5e-3; ///< V-band extinction per n_H per length [pc^-1 cm^3]
    /// Extinction curve: "CCM89" (Cardelli, Clayton & Mathis 1989 with R_V) or "grey"
    /// (A(lambda) = A_V at every wavelength: large grains; also for tests).
    std::string curve = "CCM89";
    double R_V = 3.1; ///< total-to-selective extinction A_V / E(B-V)

    /// Throws UsageError naming the offending parameter ("dust parameter albedo ...") if any
    /// value is out of range.
    void validate() const;
    /// JSON object {"kappa_V", "albedo", "g", "phase", "curve", "R_V"}.
    std::string toJson() const;
    /// Parses toJson()'s format; @p source names the file for error messages. A missing
    /// field takes its default (DustParams{}), and its name is added to @p missing (if not
    /// null) in the order of toJson(), so that the caller can warn; unknown fields are
    /// ignored. Throws Error (not UsageError: the values come from a file) on invalid JSON, a
    /// mistyped field, an unknown phase name, or a value validate() rejects.
    static DustParams fromJson(const std::string& text, const std::string& source,
                               std::vector<std::string>* missing = nullptr);
    /// "albedo = 0.6, g = 0.6": @p missing fields (from fromJson()) with this dust's values,
    /// for the warning.
    std::string missingFieldsText(const std::vector<std::string>& missing) const;
};

} // namespace nebula
