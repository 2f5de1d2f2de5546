// SPDX-License-Identifier: Apache-2.0
// End-to-end tests of nebphase (DESIGN §4): the phase table as grids and JSON, its thin
// limit, determinism, the dust it is made for, slab runs, and bad input.
#include "cli_fixture.h"

#include "nebula/core/version.h"
#include "nebula/io/grid_io.h"
#include "nebula/io/phase_table_vdb.h"
#include "nebula/physics/dust.h"

#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

using namespace nebula::clitest;

namespace {

class NebPhase : public Cli
{
protected:
    std::string text(const std::string& name) const
    {
        std::ifstream in(path(name));
        std::stringstream s;
        s << in.rdbuf();
        return s.str();
    }
    nlohmann::json json(const std::string& name) const { return nlohmann::json::parse(text(name)); }
};

/// A small, fast table; append options to change it.
const std::string SMALL = "nebphase --t-count 4 --mu-bins 16 --photons 2048 --max-photons 8192 ";

/// The values of FloatGrid @p name of @p file at voxels (i, j, 0), row by row.
std::vector<float> gridValues(const nebula::GridSet& grids, const std::string& name, int ni, int nj)
{
    const auto g = grids.floatGrid(name, "");
    const auto acc = g->getConstAccessor();
    std::vector<float> v;
    for (int j = 0; j < nj; ++j)
        for (int i = 0; i < ni; ++i)
            v.push_back(acc.getValue(openvdb::Coord(i, j, 0)));
    return v;
}

/// Mean of the phase function over mu in [a, b] [1/sr] (azimuth-independent, so the mean
/// over the bin's solid angle), in closed form: HG (g != 0) and Rayleigh.
double binMean(nebula::PhaseModel model, double g, double a, double b)
{
    const auto F = [&](double mu) {
        if (model == nebula::PhaseModel::Rayleigh) {
            return 3.0 / (16.0 * nebula::PI) * (mu + mu * mu * mu / 3.0);
        }
        return (1.0 - g * g) / (4.0 * nebula::PI * g) / std::sqrt(1.0 + g * g - 2.0 * g * mu);
    };
    return (F(b) - F(a)) / (b - a);
}

} // namespace

// ---- table mode ------------------------------------------------------------------------

TEST_F(NebPhase, TableGridsAxesMetadataDustAndJson)
{
    const Result r = run(SMALL + "--t-max 100 --albedo 0.7 --g 0.4 --phase-function hg "
                                 "--seed 5 --error 0.5 -o t.vdb --json t.json");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(r.err.empty()) << "stderr must stay quiet without -v: " << r.err;
    EXPECT_EQ(entries(), (std::vector<std::string>{"t.json", "t.vdb"}));

    const auto grids = read(path("t.vdb"));
    std::vector<std::string> names;
    for (const auto& g : grids.grids)
        names.push_back(g->getName());
    std::sort(names.begin(), names.end());
    EXPECT_EQ(names, (std::vector<std::string>{"phase", "phase.error", "phase.single"}));
    for (const std::string name : {"phase", "phase.error", "phase.single"}) {
        const auto g = grids.floatGrid(name, "");
        EXPECT_TRUE(g->transform().isIdentity()) << name << ": index space";
        EXPECT_EQ(g->evalActiveVoxelBoundingBox(),
                  openvdb::CoordBBox(openvdb::Coord(0, 0, 0), openvdb::Coord(15, 3, 0)));
        EXPECT_EQ(g->activeVoxelCount(), 16u * 4u);
    }
    const auto phase = grids.find("phase");
    EXPECT_EQ(phase->metaValue<std::string>("table"), nebula::PHASE_TABLE_KIND);
    EXPECT_EQ(phase->metaValue<double>("t_min"), 1e-4);
    EXPECT_EQ(phase->metaValue<double>("t_max"), 100.0);
    EXPECT_EQ(phase->metaValue<openvdb::Int32>("t_count"), 4);
    EXPECT_EQ(phase->metaValue<openvdb::Int32>("mu_bins"), 16);
    EXPECT_EQ(phase->metaValue<std::string>("t_spacing"), "log");
    EXPECT_EQ(phase->metaValue<openvdb::Int64>("seed"), 5);

    const auto table = nebula::readPhaseTable(grids);
    EXPECT_EQ(table.tCount, 4);
    EXPECT_EQ(table.muBins, 16);
    EXPECT_DOUBLE_EQ(table.medium.albedo, 0.7);
    EXPECT_DOUBLE_EQ(table.medium.g, 0.4);
    EXPECT_EQ(table.medium.phase, nebula::PhaseModel::HenyeyGreenstein);
    for (std::size_t k = 0; k < table.phi.size(); ++k) {
        ASSERT_TRUE(std::isfinite(table.phi[k]) && table.phi[k] >= 0.0f) << k;
        ASSERT_TRUE(std::isfinite(table.error[k]) && table.error[k] >= 0.0f) << k;
    }
    for (auto n : table.photons) {
        EXPECT_GE(n, 2048u);
        EXPECT_LE(n, 8192u);
    }

    // The file carries the dust the table was made for, and its provenance.
    EXPECT_TRUE(grids.hasDust());
    const auto dust = grids.dust();
    const nebula::DustParams defaults;
    EXPECT_EQ(dust.albedo, 0.7);
    EXPECT_EQ(dust.g, 0.4);
    EXPECT_EQ(dust.phase, nebula::PhaseModel::HenyeyGreenstein);
    EXPECT_EQ(dust.kappa_V, defaults.kappa_V);
    EXPECT_EQ(dust.R_V, defaults.R_V);
    EXPECT_EQ(grids.metaString(nebula::META_TOOL), "nebphase");
    EXPECT_NE(grids.metaString(nebula::META_COMMAND).find("--seed 5"), std::string::npos);

    // --json holds the same table.
    const auto j = json("t.json");
    EXPECT_EQ(j["t_count"], 4);
    EXPECT_EQ(j["mu_bins"], 16);
    EXPECT_EQ(j["albedo"], 0.7);
    ASSERT_EQ(j["rows"].size(), 4u);
    for (int row = 0; row < 4; ++row) {
        EXPECT_DOUBLE_EQ(j["rows"][row]["t"].get<double>(), table.t(row));
        for (int i = 0; i < 16; ++i) {
            EXPECT_EQ(j["rows"][row]["phi"][i].get<float>(), table.value(row, i));
        }
    }
}

TEST_F(NebPhase, StdoutStreamAndJsonToStdout)
{
    ASSERT_EQ(run(SMALL + "--error 0.5 -o file.vdb").code, 0);
    Result r = run(SMALL + "--error 0.5 -o - > stream.vdb");
    ASSERT_EQ(r.code, 0) << r.err;
    const auto a = read(path("file.vdb")), b = read(path("stream.vdb"));
    EXPECT_EQ(gridValues(a, "phase", 16, 4), gridValues(b, "phase", 16, 4));
    r = run(SMALL + "--error 0.5 -o other.vdb --json - > table.json");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(json("table.json")["rows"].size(), 4u);
}

TEST_F(NebPhase, SameSeedSameTableWhateverTheThreadCount)
{
    ASSERT_EQ(run(SMALL + "--error 0.5 --seed 3 --threads 1 -o one.vdb").code, 0);
    ASSERT_EQ(run(SMALL + "--error 0.5 --seed 3 --threads 2 -o two.vdb").code, 0);
    ASSERT_EQ(run(SMALL + "--error 0.5 --seed 3 -o all.vdb").code, 0);
    ASSERT_EQ(run(SMALL + "--error 0.5 --seed 4 -o other.vdb").code, 0);
    const auto one = read(path("one.vdb")), two = read(path("two.vdb"));
    const auto all = read(path("all.vdb")), other = read(path("other.vdb"));
    for (const std::string name : {"phase", "phase.error"}) {
        const auto v1 = gridValues(one, name, 16, 4);
        EXPECT_EQ(v1, gridValues(two, name, 16, 4)) << name;
        EXPECT_EQ(v1, gridValues(all, name, 16, 4)) << name;
        // Another seed: other photons, so (almost) every value differs.
        const auto v2 = gridValues(other, name, 16, 4);
        int differ = 0;
        for (std::size_t k = 0; k < v1.size(); ++k)
            differ += v1[k] != v2[k];
        EXPECT_GT(differ, int(v1.size()) / 2) << name;
    }
}

TEST_F(NebPhase, ThinLimitIsAlbedoTimesPhaseFunction)
{
    // Row 0, t = 1e-4: single scattering, Phi = albedo p(mu) up to O(t) = 1e-4 relative.
    struct Case
    {
        std::string phase;
        nebula::PhaseModel model;
        double albedo, g;
    };
    for (const Case& c : {Case{"hg", nebula::PhaseModel::HenyeyGreenstein, 0.8, 0.6},
                          Case{"hg", nebula::PhaseModel::HenyeyGreenstein, 0.5, -0.3},
                          Case{"rayleigh", nebula::PhaseModel::Rayleigh, 1.0, 0.0}}) {
        std::ostringstream cmd;
        cmd << "nebphase --t-min 1e-4 --t-max 1e-2 --t-count 2 --mu-bins 16 --photons 4096 "
            << "--max-photons 8192 --error 0.5 --phase-function " << c.phase << " --albedo "
            << c.albedo << " --g " << c.g << " -o thin.vdb";
        const Result r = run(cmd.str());
        ASSERT_EQ(r.code, 0) << cmd.str() << "\n" << r.err;
        const auto table = nebula::readPhaseTable(read(path("thin.vdb")));
        ASSERT_EQ(table.t(0), 1e-4);
        for (int i = 0; i < table.muBins; ++i) {
            const double lo = -1.0 + 2.0 * i / table.muBins, hi = lo + 2.0 / table.muBins;
            const double expected = c.albedo * binMean(c.model, c.g, lo, hi);
            const double err = table.error[std::size_t(i)];
            EXPECT_NEAR(table.value(0, i), expected, 3.0 * err + 1e-3 * expected)
                << c.phase << " g " << c.g << ", bin " << i << " [" << lo << ", " << hi << "]";
        }
    }
}

TEST_F(NebPhase, DustFromTheInputAndOptionsOverride)
{
    ASSERT_EQ(run("nebgen --res 16 --albedo 0.5 --g 0.3 --kappa-v 0.002 -o in.vdb").code, 0);
    Result r = run(SMALL + "--error 0.5 -i in.vdb -o a.vdb");
    ASSERT_EQ(r.code, 0) << r.err;
    const auto a = read(path("a.vdb"));
    // Only the table: the input's grids are not passed through; its dust travels.
    EXPECT_EQ(a.grids.size(), 3u);
    EXPECT_EQ(a.find("density"), nullptr);
    auto table = nebula::readPhaseTable(a);
    EXPECT_EQ(table.medium.albedo, 0.5);
    EXPECT_EQ(table.medium.g, 0.3);
    EXPECT_EQ(a.dust().kappa_V, 0.002);
    EXPECT_EQ(a.dust().albedo, 0.5);
    EXPECT_TRUE(a.stars().empty());

    // Options override the input's dust.
    r = run(SMALL + "--error 0.5 -i in.vdb --g -0.2 --phase-function rayleigh -o b.vdb");
    ASSERT_EQ(r.code, 0) << r.err;
    const auto b = read(path("b.vdb"));
    table = nebula::readPhaseTable(b);
    EXPECT_EQ(table.medium.albedo, 0.5);
    EXPECT_EQ(table.medium.g, -0.2);
    EXPECT_EQ(table.medium.phase, nebula::PhaseModel::Rayleigh);
    EXPECT_EQ(b.dust().g, -0.2);
    EXPECT_EQ(b.dust().phase, nebula::PhaseModel::Rayleigh);
    EXPECT_EQ(b.dust().kappa_V, 0.002);

    // The same through a pipe.
    r = run("nebgen --res 16 --albedo 0.5 --g 0.3 --kappa-v 0.002 -o - | " + SMALL +
            "--error 0.5 -i - -o - > piped.vdb");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_EQ(gridValues(read(path("piped.vdb")), "phase", 16, 4), gridValues(a, "phase", 16, 4));

    // An input without nebula:dust: the defaults, with a warning.
    auto g = openvdb::FloatGrid::create(0.0f);
    g->setName("density");
    g->tree().setValue(openvdb::Coord(0), 1.0f);
    writeVdb(path("nodust.vdb"), {g}, openvdb::MetaMap());
    r = run(SMALL + "--error 0.5 -i nodust.vdb -o c.vdb");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("warning: nodust.vdb has no nebula:dust"), std::string::npos) << r.err;
    EXPECT_EQ(nebula::readPhaseTable(read(path("c.vdb"))).medium.albedo,
              nebula::DustParams().albedo);
}

TEST_F(NebPhase, VerboseReportAndWarningWhenTheErrorTargetIsMissed)
{
    Result r = run("nebphase -v --t-count 2 --t-max 1 --mu-bins 16 --photons 1024 "
                   "--max-photons 2048 --error 1e-4 -o w.vdb");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_NE(r.err.find("nebphase: worst relative error of Phi (mu > 0, t <= 10): "),
              std::string::npos)
        << r.err;
    EXPECT_NE(r.err.find("4096 photons in all"), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("nebphase: warning: worst relative error of Phi is "), std::string::npos)
        << r.err;
    EXPECT_NE(r.err.find("above --error 0.0001: --max-photons 2048 reached"), std::string::npos)
        << r.err;
    // -q: no warning.
    r = run("nebphase -q --t-count 2 --t-max 1 --mu-bins 16 --photons 1024 "
            "--max-photons 2048 --error 1e-4 -o w.vdb");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(r.err.empty()) << r.err;
}

// ---- slab mode -------------------------------------------------------------------------

TEST_F(NebPhase, SlabJsonNextEventAndAnalog)
{
    const double tau = 1.0, mu0 = 0.5, albedo = 0.9;
    Result r = run("nebphase --slab --tau 1 --mu0 0.5 --albedo 0.9 --g 0 --photons 200000 "
                   "--bins 10 > ne.json");
    ASSERT_EQ(r.code, 0) << r.err;
    EXPECT_TRUE(r.err.empty()) << r.err;
    const auto ne = json("ne.json");
    EXPECT_EQ(ne["slab"]["tau"], tau);
    EXPECT_EQ(ne["slab"]["mu0"], mu0);
    EXPECT_EQ(ne["slab"]["albedo"], albedo);
    EXPECT_EQ(ne["slab"]["g"], 0.0);
    EXPECT_EQ(ne["slab"]["phase"], "hg");
    EXPECT_EQ(ne["photons"], 200000);
    EXPECT_GT(ne["events"].get<double>(), 200000.0);
    EXPECT_EQ(ne["estimator"], "next-event");
    EXPECT_EQ(ne["seed"], 1);
    const auto value = [](const nlohmann::json& e) { return e["value"].get<double>(); };
    const auto error = [](const nlohmann::json& e) { return e["error"].get<double>(); };
    const auto& R = ne["reflected"]["diffuse"];
    const auto& T = ne["transmitted"]["diffuse"];
    const auto& D = ne["transmitted"]["direct"];
    const auto& A = ne["absorbed"];
    const auto& B = ne["balance"];
    const auto& RR = ne["roulette"];
    for (const auto* e : {&R, &T, &D, &A, &B, &RR}) {
        ASSERT_TRUE(e->contains("value") && e->contains("error")) << *e;
    }
    // Next-event forces the first interaction: the direct beam is exact.
    EXPECT_NEAR(value(D), std::exp(-tau / mu0), 1e-12);
    EXPECT_LT(error(D), 1e-9);
    // Energy: balanced in expectation (roulette is zero in expectation).
    EXPECT_NEAR(value(B), 1.0, 3.0 * error(B));
    EXPECT_NEAR(value(R) + value(T) + value(A) + value(D), 1.0, 3.0 * (error(B) + error(RR)));
    EXPECT_GT(value(R), 0.05);
    EXPECT_GT(value(T), 0.05);

    // Angular bins: cosine to the outward normal of the face, 0 .. 1, summing to the totals.
    for (const std::string face : {"reflected", "transmitted"}) {
        const auto& bins = ne["angular"][face];
        ASSERT_EQ(bins.size(), 10u) << face;
        double sum = 0.0;
        for (int k = 0; k < 10; ++k) {
            EXPECT_NEAR(bins[k]["mu_lo"].get<double>(), 0.1 * k, 1e-12) << face << k;
            EXPECT_NEAR(bins[k]["mu_hi"].get<double>(), 0.1 * (k + 1), 1e-12) << face << k;
            EXPECT_GE(bins[k]["per_sr"].get<double>(), 0.0);
            EXPECT_GE(bins[k]["error"].get<double>(), 0.0);
            sum += bins[k]["per_sr"].get<double>() * 2.0 * nebula::PI * 0.1;
        }
        EXPECT_NEAR(sum, value(ne[face]["diffuse"]), 1e-9) << face;
        // Isotropic scattering in a slab of tau 1: grazing light is attenuated, so the power
        // per sr grows from mu = 0 to mu = 1 on both faces (by a factor > 3 in single
        // scattering), which also checks that the reflected bins are mirrored.
        EXPECT_GT(bins[9]["per_sr"].get<double>(), 2.0 * bins[0]["per_sr"].get<double>()) << face;
    }

    // The analog (MCML) estimator: balance exact photon by photon, and it agrees with
    // next-event within the combined standard errors.
    r = run("nebphase --slab --tau 1 --mu0 0.5 --albedo 0.9 --g 0 --photons 100000 "
            "--bins 10 --estimator analog > analog.json");
    ASSERT_EQ(r.code, 0) << r.err;
    const auto an = json("analog.json");
    EXPECT_EQ(an["estimator"], "analog");
    EXPECT_NEAR(value(an["balance"]), 1.0, 1e-9);
    for (const auto& key : {std::vector<std::string>{"reflected", "diffuse"},
                            std::vector<std::string>{"transmitted", "diffuse"},
                            std::vector<std::string>{"transmitted", "direct"}}) {
        const auto& x = an[key[0]][key[1]];
        const auto& y = ne[key[0]][key[1]];
        EXPECT_NEAR(value(x), value(y), 3.0 * std::hypot(error(x), error(y)))
            << key[0] << " " << key[1];
    }
    EXPECT_NEAR(value(an["absorbed"]), value(A), 3.0 * std::hypot(error(an["absorbed"]), error(A)));
}

// ---- help and bad input ----------------------------------------------------------------

TEST_F(NebPhase, HelpStartsWithExamplesAndVersion)
{
    ASSERT_EQ(run("nebphase --help > help.txt").code, 0);
    const std::string help = text("help.txt");
    EXPECT_EQ(help.rfind("nebphase - ", 0), 0u) << help.substr(0, 80);
    const auto ex = help.find("Examples:"), opts = help.find("Options:");
    ASSERT_NE(ex, std::string::npos);
    ASSERT_NE(opts, std::string::npos);
    EXPECT_LT(ex, opts);
    ASSERT_EQ(run("nebphase --man > man.txt").code, 0); // the method: in the man page
    const std::string man = text("man.txt");
    EXPECT_NE(man.find("NOT passed through"), std::string::npos);
    EXPECT_NE(man.find("exp(\\-tau/mu0)"), std::string::npos);
    ASSERT_EQ(run("nebphase --version > version.txt").code, 0);
    EXPECT_EQ(text("version.txt").rfind("nebphase " NEBULA_VERSION_STRING, 0), 0u);
}

TEST_F(NebPhase, BadInputNamesTheOptionAndLeavesNoFile)
{
    const std::string t = SMALL + "--json t.json -o t.vdb ";
    expectFailure(t + "--albedo 1.5", 2, "--albedo");
    expectFailure(t + "--albedo -0.1", 2, "--albedo");
    expectFailure(t + "--g 1", 2, "--g");
    expectFailure(t + "--g -1.5", 2, "--g");
    expectFailure(t + "--phase-function mie", 2, "--phase-function");
    expectFailure(t + "--photons 0", 2, "--photons");
    // Not wrapped around to a huge unsigned value.
    expectFailure(t + "--photons -5", 2,
                  "--photons: expected an integer in [1, 18446744073709551615], got -5");
    expectFailure("nebphase --photons 100 --max-photons 10 -o t.vdb", 2, "--max-photons");
    expectFailure(t + "--t-min 1 --t-max 1", 2, "--t-max");
    expectFailure(t + "--t-min 0", 2, "--t-min");
    expectFailure(t + "--t-count 1", 2, "--t-count");
    expectFailure(t + "--mu-bins 15", 2, "--mu-bins");
    expectFailure(t + "--error 0", 2, "--error");
    expectFailure(t + "--tau 1", 2, "--tau");
    expectFailure(SMALL + "--albedo 0.5", 2, "-o/--output is required");
    expectFailure("nebphase --slab --tau 0", 2, "--tau");
    expectFailure("nebphase --slab --tau -1", 2, "--tau");
    expectFailure("nebphase --slab --tau nan", 2, "--tau");
    expectFailure("nebphase --slab --tau 1 --mu0 0", 2, "--mu0");
    expectFailure("nebphase --slab --tau 1 --mu0 1.5", 2, "--mu0");
    expectFailure("nebphase --slab --tau 1 --photons 0", 2, "--photons");
    expectFailure("nebphase --slab --tau 1 --bins 0", 2, "--bins");
    expectFailure("nebphase --slab --tau 1 --albedo 2", 2, "--albedo");
    expectFailure("nebphase --slab --tau 1 --estimator mcml", 2, "--estimator");
    expectFailure("nebphase --slab --albedo 0.5", 2, "--slab needs --tau");
    expectFailure("nebphase --slab --tau 1 -o t.vdb", 2, "--output is for table mode");
    expectFailure("nebphase --slab --tau 1 --mu-bins 16", 2, "--mu-bins is for table mode");
    expectFailure("nebphase --bogus -o t.vdb", 2, "--bogus");

    // Files: missing, not a VDB, bad nebula:dust, unwritable outputs.
    expectFailure(t + "-i nowhere.vdb", 1, "nowhere.vdb: cannot open file");
    std::ofstream(path("text.vdb")) << "this is not a grid file\n";
    expectFailure(t + "-i text.vdb", 1, "text.vdb: not a VDB file");
    expectFailure("nebphase --slab --tau 1 -i text.vdb", 1, "text.vdb: not a VDB file");
    auto g = openvdb::FloatGrid::create(0.0f);
    g->setName("density");
    openvdb::MetaMap meta;
    meta.insertMeta(
        nebula::META_DUST,
        openvdb::StringMetadata(
            R"({"kappa_V":0.0015,"albedo":2,"g":0.6,"phase":"hg","curve":"CCM89","R_V":3.1})"));
    writeVdb(path("baddust.vdb"), {g}, meta);
    expectFailure(t + "-i baddust.vdb", 1, "baddust.vdb: metadata nebula:dust");
    expectFailure(SMALL + "-o no/such/folder/t.vdb", 1, "no/such/folder/t.vdb");
    expectFailure(SMALL + "-o t.vdb --json no/such/folder/t.json", 1, "no/such/folder/t.json");
    expectFailure(SMALL + "-o - --json -", 2, "--json - and -o -");
    expectFailure(SMALL + "-o t.vdb --json ./t.vdb", 2, "are the same file");
}
