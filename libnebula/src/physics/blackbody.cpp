// SPDX-License-Identifier: Apache-2.0
#include "nebula/physics/blackbody.h"

#include "nebula/core/error.h"
#include "nebula/core/format.h"

namespace nebula {

using detail::numberText;

double planck(double lambda_m, double T)
{
    if (!(lambda_m > 0.0) || !std::isfinite(lambda_m)) {
        throw Error("planck: wavelength must be a finite number > 0 [m], got " +
                    numberText(lambda_m));
    }
    if (!(T > 0.0) || !std::isfinite(T)) {
        throw Error("planck: temperature must be a finite number > 0 [K], got " + numberText(T));
    }
    // B_lambda = 2 h c^2 / lambda^5 / (exp(h c / (lambda k T)) - 1).
    const double x = PLANCK_H * SPEED_OF_LIGHT / (lambda_m * BOLTZMANN_K * T);
    const double l2 = lambda_m * lambda_m;
    return 2.0 * PLANCK_H * SPEED_OF_LIGHT * SPEED_OF_LIGHT / (l2 * l2 * lambda_m) / std::expm1(x);
}

double planckPerNm(double lambda_nm, double T)
{
    if (!(lambda_nm > 0.0) || !std::isfinite(lambda_nm)) {
        throw Error("planck: wavelength must be a finite number > 0 [nm], got " +
                    numberText(lambda_nm));
    }
    return planck(lambda_nm * 1e-9, T) * 1e-9;
}

} // namespace nebula
