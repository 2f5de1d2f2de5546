// SPDX-License-Identifier: Apache-2.0
// The integrators' registry (render/integrator.h): lookup by name, refusals, documentation.
#include "nebula/core/error.h"
#include "nebula/render/integrator.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <functional>
#include <set>
#include <string>

namespace {

std::string usageError(const std::function<void()>& f)
{
    try {
        f();
    } catch (const nebula::UsageError& e) {
        return e.what();
    }
    return "no usage error";
}

TEST(IntegratorRegistry, EachIntegratorIsFoundByItsNameAndDocumented)
{
    const auto& types = nebula::integratorTypes();
    ASSERT_EQ(types.size(), 3u);
    std::set<std::string> names;
    for (const nebula::IntegratorType* t : types) {
        EXPECT_EQ(&nebula::integratorType(t->name), t);
        EXPECT_FALSE(t->doc.empty()) << t->name;
        EXPECT_FALSE(t->chosenBy.empty()) << t->name;
        EXPECT_FALSE(t->comment.empty()) << t->name;
        EXPECT_FALSE(t->options.empty()) << t->name;
        for (const auto& o : t->options)
            EXPECT_EQ(o.rfind("--", 0), 0u) << t->name << ": " << o;
        EXPECT_TRUE(t->validate && t->checkInput && t->render && t->describe) << t->name;
        names.insert(t->name);
    }
    EXPECT_EQ(names, (std::set<std::string>{"fast", "path", "spectral"}));
    // The path tracer alone reads --spp and --seed.
    for (const nebula::IntegratorType* t : types) {
        const bool spp = std::count(t->options.begin(), t->options.end(), "--spp") > 0;
        EXPECT_EQ(spp, t->name == "path") << t->name;
    }
}

TEST(IntegratorRegistry, AnUnknownNameIsRefusedWithTheKnownOnes)
{
    const std::string m = usageError([] { nebula::integratorType("mc"); });
    EXPECT_NE(m.find("--integrator mc"), std::string::npos) << m;
    EXPECT_NE(m.find("fast, path, spectral"), std::string::npos) << m;
}

TEST(IntegratorRegistry, TheOptionsChooseOne)
{
    nebula::RenderOptions opts;
    EXPECT_EQ(nebula::chosenIntegrator(opts).name, "fast");
    opts.integrator = "path";
    EXPECT_EQ(nebula::chosenIntegrator(opts).name, "path");
    opts.spectral.enabled = true; // --spectral is the fast integrator's mode
    EXPECT_NE(usageError([&] { nebula::chosenIntegrator(opts); }).find("--spectral"),
              std::string::npos);
    opts.integrator = "fast";
    EXPECT_EQ(nebula::chosenIntegrator(opts).name, "spectral");
    opts.spectral.enabled = false;
    opts.integrator = "spectral"; // chosen by its flag, not by name
    EXPECT_NE(usageError([&] { nebula::chosenIntegrator(opts); }).find("--spectral"),
              std::string::npos);
}

TEST(IntegratorRegistry, EachValidatesItsOwnOptions)
{
    nebula::RenderOptions opts;
    opts.levels = 2; // levels need a phase table; the path tracer takes none
    EXPECT_NE(usageError([&] {
                  nebula::integratorType("fast").validate(opts);
              }).find("--levels needs a phase table"),
              std::string::npos);
    EXPECT_NE(usageError([&] {
                  nebula::integratorType("path").validate(opts);
              }).find("--levels is for the fast integrator"),
              std::string::npos);
    opts.levels = -1;
    opts.spp = 0;
    EXPECT_NE(usageError([&] { nebula::integratorType("path").validate(opts); }).find("--spp"),
              std::string::npos);
    EXPECT_NO_THROW(nebula::integratorType("fast").validate(opts)); // --spp is not its own
}

} // namespace
