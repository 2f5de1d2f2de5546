// SPDX-License-Identifier: Apache-2.0
/// @file integrator.cpp
/// The registry of integrators (render/integrator.h): one line per integrator, each defined
/// in its own file.

#include "nebula/render/integrator.h"

#include "frame.h"

#include "nebula/core/error.h"

namespace nebula {

namespace detail {
// Each integrator's type, defined in its own file. A new integrator: one line here, and its
// entry in integratorTypes().
const IntegratorType& fastIntegrator();     // fast.cpp
const IntegratorType& pathIntegrator();     // path_tracer.cpp
const IntegratorType& spectralIntegrator(); // spectral.cpp
} // namespace detail

const std::vector<const IntegratorType*>& integratorTypes()
{
    static const std::vector<const IntegratorType*> types{
        &detail::fastIntegrator(), &detail::pathIntegrator(), &detail::spectralIntegrator()};
    return types;
}

const IntegratorType& integratorType(const std::string& name, const std::string& option)
{
    std::string known;
    for (const IntegratorType* type : integratorTypes()) {
        if (type->name == name) return *type;
        known += (known.empty() ? "" : ", ") + type->name;
    }
    throw UsageError(option + " " + name + ": no such integrator; the integrators are " + known);
}

const IntegratorType& chosenIntegrator(const RenderOptions& opts)
{
    // The spectral renderer is the fast integrator's spectral mode on the command line.
    const IntegratorType& spectral = detail::spectralIntegrator();
    if (opts.spectral.enabled) {
        if (opts.integrator != detail::fastIntegrator().name) {
            throw UsageError("--spectral is for the fast integrator (--integrator fast)");
        }
        return spectral;
    }
    const IntegratorType& type = integratorType(opts.integrator);
    if (&type == &spectral) {
        throw UsageError("--integrator " + type.name + ": chosen by " + type.chosenBy);
    }
    return type;
}

namespace detail {

void warnUnusedLevels(const IntegratorInput& input, const RenderOptions& opts, bool field,
                      const Run& run)
{
    if (opts.levels < 0 && !opts.phaseTable && !field && !input.pyramidLevel.empty()) {
        run.warn(input.source + " has pyramid levels (" + input.pyramidLevel +
                 ", ...), which only a phase table uses: this image is single scattering. "
                 "Pass --phase (nebphase -i " +
                 input.source + " -o phase.vdb) to use them, or --levels 0 to say you mean it");
    }
}

} // namespace detail

} // namespace nebula
