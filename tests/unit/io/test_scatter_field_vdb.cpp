// SPDX-License-Identifier: Apache-2.0
// nebscatter's field as grids (io/scatter_field_vdb.h): the round trip of the grids and the
// metadata, the sum readScatterMoments() forms, and its errors.
#include "nebula/io/scatter_field_vdb.h"

#include "nebula/core/error.h"
#include "nebula/core/units.h"
#include "nebula/io/grid_names.h"
#include "nebula/io/volume_vdb.h"
#include "nebula/physics/spherical_harmonics.h"

#include <openvdb/openvdb.h>

#include "test_util.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>

using namespace nebula;
using nebula::test::errorMessage;

namespace {

/// A small R, G, B field of order 1 with two sources on a 4^3 lattice at lo (-1, 0, 2); each
/// channel's value a distinct function of the point, the source and the channel.
struct SmallField
{
    ScatterFieldMeta meta;
    SparseVolume a, b;
    std::vector<std::uint8_t> active;
    openvdb::math::Transform::Ptr xform = openvdb::math::Transform::createLinearTransform(2.0);

    static float value(std::size_t v, int ch, int source)
    {
        return float(v + 1) * 0.5f + ch + 100 * source;
    }

    SmallField()
    {
        meta.settings.order = 1;
        meta.settings.fieldLevel = 1;
        meta.settings.perStar = true;
        meta.settings.packets = 1000;
        meta.settings.seed = 7;
        meta.sources = {
            {ScatterSource::oneStar(1),
             1000,
             3000,
             {1, 2, 3},
             {0.1, 0.2, 0.3},
             {0.4, 0.5, 0.6},
             0.02},
            {ScatterSource::emission(), 1000, 2000, {4, 5, 6}, {0, 0, 0}, {1, 1, 1}, 0.03}};
        meta.stars = {Star{"b", {4, 5, 6}, 1.0, 9000.0}, Star{"a", {1, 2, 3}, 2.0, 6000.0}};
        meta.wavelengths = {650, 550, 450};
        meta.scene.minStarDistance = 0.25;
        meta.scene.densityGrid = "density";
        meta.scene.emissionGrid = "emission";
        meta.indexToWorld.m = {1, 0, 0, 0, 1, 0, 0, 0, 1};
        meta.indexToWorld.t = Vec3(0.5, 0.5, 0.5);
        meta.seconds = 1.5;
        const int channels = shCount(1) * 3;
        a = SparseVolume({-1, 0, 2}, {4, 4, 4}, channels);
        b = SparseVolume({-1, 0, 2}, {4, 4, 4}, channels);
        active.assign(64, 0); // per lattice cell, x fastest
        for (std::size_t c = 0; c < active.size(); ++c)
            active[c] = c % 3 != 0; // some cells are not written
        for (std::size_t v = 0; v < a.voxelCount(); ++v) {
            for (int ch = 0; ch < channels; ++ch) {
                a.writable(v)[ch] = value(v, ch, 0);
                b.writable(v)[ch] = value(v, ch, 1);
            }
        }
    }

    GridSet written() const
    {
        GridSet grids;
        grids.source = "field.vdb";
        writeScatterField(grids, meta, {&a, &b}, active, *xform, false);
        return grids;
    }
};

const std::string WHAT = "field.vdb: the field";
const std::string RERUN = "; rerun";

} // namespace

TEST(ScatterFieldVdb, MetadataRoundTrip)
{
    openvdb::initialize();
    const SmallField f;
    const GridSet grids = f.written();
    EXPECT_EQ(grids.grids.size(), 2u * 4u * 3u); // 2 sources x 4 moments x R, G, B
    ASSERT_TRUE(grids.find(scatterGridName("star_a", 1, -1, 2)));
    const auto back = readScatterFieldMeta(grids, false);
    ASSERT_TRUE(back);
    EXPECT_EQ(back->settings.order, 1);
    EXPECT_EQ(back->settings.fieldLevel, 1);
    EXPECT_TRUE(back->settings.perStar);
    EXPECT_EQ(back->settings.packets, 1000u);
    EXPECT_EQ(back->settings.seed, 7u);
    ASSERT_EQ(back->sources.size(), 2u);
    // Typed sources: the second star (named "star_a" in the grids), then the emission.
    EXPECT_EQ(back->sources[0].source, ScatterSource::oneStar(1));
    EXPECT_EQ(back->sources[1].source, ScatterSource::emission());
    EXPECT_EQ(back->sources[0].flights, 3000u);
    EXPECT_EQ(back->sources[0].escaped, (std::vector<double>{0.1, 0.2, 0.3}));
    EXPECT_DOUBLE_EQ(back->sources[1].relativeError, 0.03);
    ASSERT_EQ(back->stars.size(), 2u);
    EXPECT_EQ(back->stars[1].name, "a");
    EXPECT_DOUBLE_EQ(back->stars[1].position[2], 3.0);
    EXPECT_EQ(back->wavelengths, f.meta.wavelengths);
    EXPECT_DOUBLE_EQ(back->scene.minStarDistance, 0.25);
    EXPECT_EQ(back->scene.densityGrid, "density");
    EXPECT_DOUBLE_EQ(back->indexToWorld.t.y, 0.5);
    EXPECT_DOUBLE_EQ(back->indexToWorld.m[4], 1.0);
    // No spectral field in this file.
    EXPECT_FALSE(readScatterFieldMeta(grids, true));
}

// The sum of the sources, each times its factor, with J turned back into c_00; cells not
// written are zero.
TEST(ScatterFieldVdb, MomentsAreTheFactoredSumOfTheSources)
{
    openvdb::initialize();
    const SmallField f;
    const GridSet grids = f.written();
    const auto meta = *readScatterFieldMeta(grids, false);
    const std::vector<std::vector<double>> factors{{2.0, 2.0, 2.0}, {0.5, 1.0, 3.0}};
    const Affine fieldMap = affineFromTransform(*f.xform);
    const SparseVolume m = readScatterMoments(grids, meta, false, factors, fieldMap, WHAT, RERUN);
    ASSERT_EQ(m.channels(), f.a.channels());
    EXPECT_DOUBLE_EQ(m.indexToWorld.m[0], 2.0);
    int checked = 0;
    for (int k = 2; k < 6; ++k)
        for (int j = 0; j < 4; ++j)
            for (int i = -1; i < 3; ++i) {
                ASSERT_TRUE(m.contains(i, j, k));
                const std::size_t v = f.a.index(i, j, k);
                const std::size_t cell = std::size_t(((k - 2) * 4 + j) * 4 + i + 1);
                for (int ch = 0; ch < m.channels(); ++ch) {
                    const int c = ch % 3;
                    const double expected =
                        f.active[cell]
                            ? factors[0][std::size_t(c)] * SmallField::value(v, ch, 0) +
                                  factors[1][std::size_t(c)] * SmallField::value(v, ch, 1)
                            : 0.0;
                    EXPECT_NEAR(m.voxel(m.index(i, j, k))[ch], expected, 1e-5 * expected)
                        << i << " " << j << " " << k << " channel " << ch;
                    ++checked;
                }
            }
    EXPECT_EQ(checked, 64 * 12);
    // One border cell around the written ones.
    EXPECT_TRUE(m.contains(-2, -1, 1));
    EXPECT_EQ(m.voxel(m.index(-2, -1, 1))[0], 0.0f);
}

TEST(ScatterFieldVdb, MissingOrMisplacedGridsAndBrokenMetadataNameTheirCause)
{
    openvdb::initialize();
    const SmallField f;
    const std::vector<std::vector<double>> factors{{1, 1, 1}, {1, 1, 1}};
    const Affine fieldMap = affineFromTransform(*f.xform);
    {
        GridSet grids = f.written();
        const auto meta = *readScatterFieldMeta(grids, false);
        const std::string name = scatterGridName("emission", 1, 0, 1);
        openvdb::GridPtrVec kept;
        for (auto& g : grids.grids)
            if (g->getName() != name) kept.push_back(g);
        grids.grids = kept;
        EXPECT_EQ(errorMessage([&] {
                      readScatterMoments(grids, meta, false, factors, fieldMap, WHAT, RERUN);
                  }),
                  WHAT + " lacks its grid \"" + name + "\"" + RERUN);
    }
    {
        GridSet grids = f.written();
        const auto meta = *readScatterFieldMeta(grids, false);
        const std::string name = scatterGridName("star_a", 0, 0, 0);
        grids.find(name)->setTransform(openvdb::math::Transform::createLinearTransform(1.0));
        const std::string e = errorMessage(
            [&] { readScatterMoments(grids, meta, false, factors, fieldMap, WHAT, RERUN); });
        EXPECT_NE(e.find("grid \"" + name + "\" is not on field level 1's transform"),
                  std::string::npos)
            << e;
    }
    {
        GridSet grids = f.written();
        grids.setMetaString(META_SCATTER, "{\"order\": 9}");
        const std::string e = errorMessage([&] { readScatterFieldMeta(grids, false); });
        EXPECT_NE(e.find("field.vdb: nebula:scatter metadata is not nebscatter's"),
                  std::string::npos)
            << e;
    }
    {
        GridSet grids = f.written();
        grids.setMetaString(META_SCATTER, "");
        const std::string e = errorMessage([&] { readScatterFieldMeta(grids, false); });
        EXPECT_NE(e.find("looks like a scattered-light field but the file has no nebula:scatter"),
                  std::string::npos)
            << e;
    }
}

// A source is typed in memory and named only in the file: "stars", "star_<name>" of one of
// the field's stars, "emission"; any other name is refused, naming it.
TEST(ScatterFieldVdb, SourcesAreNamedOnlyInTheFile)
{
    const std::vector<Star> stars{Star{"b", {4, 5, 6}, 1.0, 9000.0},
                                  Star{"star_b", {1, 2, 3}, 2.0, 6000.0}};
    for (const auto& source : {ScatterSource::allStars(), ScatterSource::oneStar(0),
                               ScatterSource::oneStar(1), ScatterSource::emission()}) {
        const std::string name = scatterSourceName(source, stars);
        EXPECT_EQ(parseScatterSource(name, stars, "f.vdb"), source) << name;
    }
    EXPECT_EQ(scatterSourceName(ScatterSource::oneStar(1), stars), "star_star_b");
    EXPECT_EQ(scatterSourceName(ScatterSource::allStars(), stars), "stars");
    EXPECT_EQ(errorMessage([&] { parseScatterSource("star_c", stars, "f.vdb"); }),
              "f.vdb: source \"star_c\" is none of \"stars\", \"emission\" or "
              "\"star_<name>\" of one of its stars");

    openvdb::initialize();
    SmallField f;
    f.meta.stars[1].name = "c"; // written as "star_c"; renamed below to name no star
    GridSet grids = f.written();
    const nlohmann::json meta = nlohmann::json::parse(grids.metaString(META_SCATTER));
    EXPECT_EQ(meta.at("sources").at(0).at("name"), "star_c");
    nlohmann::json renamed = meta;
    renamed["sources"][0]["name"] = "star_a";
    grids.setMetaString(META_SCATTER, renamed.dump());
    const std::string e = errorMessage([&] { readScatterFieldMeta(grids, false); });
    EXPECT_NE(e.find("field.vdb: nebula:scatter: source \"star_a\" is none of"), std::string::npos)
        << e;
}

// storedFieldValue() against brute force: within 2^-bits of the reference, a multiple of the
// step 2^(e + 1 - bits) (2^e <= |reference| < 2^(e + 1)), so its float's low bits are zero;
// the value itself at FIELD_FLOAT_BITS; against |value| where the reference is 0.
TEST(ScatterFieldVdb, StoredValuesKeepTheirBitsWithinTheStatedBound)
{
    std::uint32_t state = 12345;
    const auto uniform = [&] { // xorshift32 in [0, 1)
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        return double(state) / 4294967296.0;
    };
    for (const int bits : {FIELD_MIN_BITS, 8, FIELD_HALF_BITS, 16}) {
        for (int i = 0; i < 20000; ++i) {
            const float ref = float(std::ldexp(0.5 + uniform(), int(uniform() * 60.0) - 30));
            const float value = float((uniform() * 6.0 - 3.0) * ref); // |c_lm| up to 3 c_00
            const float stored = storedFieldValue(value, ref, bits);
            ASSERT_LE(std::abs(double(stored) - double(value)), std::ldexp(double(ref), -bits))
                << value << " against " << ref << " at " << bits << " bits";
            int e = 0;
            std::frexp(ref, &e); // 2^(e - 1) <= ref < 2^e: the step is 2^(e - bits)
            const double k = double(stored) / std::ldexp(1.0, e - bits);
            ASSERT_EQ(k, std::round(k)) << stored;
            // At most bits + 2 significant bits (|k| <= 3 * 2^bits): the float's low 22 - bits
            // bits are 0.
            std::uint32_t u = 0;
            std::memcpy(&u, &stored, sizeof u);
            ASSERT_EQ(u & ((1u << (22 - bits)) - 1u), 0u) << stored;
        }
    }
    EXPECT_EQ(storedFieldValue(0.1234567f, 3.0f, FIELD_FLOAT_BITS), 0.1234567f);
    EXPECT_EQ(storedFieldValue(0.0f, 1.0f, 8), 0.0f);
    // No reference (J of 0): relative to the value itself.
    EXPECT_NEAR(storedFieldValue(0.1234567f, 0.0f, 8), 0.1234567f, 0.1234567 / 256.0);
    EXPECT_NE(storedFieldValue(0.1234567f, 0.0f, 8), 0.1234567f);
}

// A field written to 8 bits: every grid value within 2^-8 of its cell's c_00 in the grid's
// units (J for the J grids) of the float field's, the bits recorded and read back; a field
// without "stored_bits" (before --precision) reads as floats, one out of range is refused.
TEST(ScatterFieldVdb, StoredBitsBoundTheErrorAndAreRecorded)
{
    openvdb::initialize();
    SmallField f;
    const GridSet exact = f.written();
    f.meta.storedBits = 8;
    const GridSet stored = f.written();
    EXPECT_EQ(readScatterFieldMeta(exact, false)->storedBits, FIELD_FLOAT_BITS);
    EXPECT_EQ(readScatterFieldMeta(stored, false)->storedBits, 8);
    const double c00PerJ = 4.0 * PI * (0.5 / std::sqrt(PI));
    int changed = 0, checked = 0;
    for (const auto& g : exact.grids) {
        const auto a = openvdb::gridPtrCast<openvdb::FloatGrid>(g);
        const auto b = openvdb::gridPtrCast<openvdb::FloatGrid>(stored.find(g->getName()));
        ASSERT_TRUE(a && b) << g->getName();
        ASSERT_EQ(a->activeVoxelCount(), b->activeVoxelCount());
        const int l = g->metaValue<int>("l");
        const std::string source = g->metaValue<std::string>("source");
        const int c = g->getName().back() == 'R' ? 0 : g->getName().back() == 'G' ? 1 : 2;
        const auto j =
            openvdb::gridPtrCast<openvdb::FloatGrid>(exact.find(scatterGridName(source, 0, 0, c)));
        const auto bAcc = b->getConstAccessor();
        const auto jAcc = j->getConstAccessor();
        for (auto it = a->cbeginValueOn(); it; ++it) {
            const double ref = jAcc.getValue(it.getCoord()) * (l == 0 ? 1.0 : c00PerJ);
            const double got = bAcc.getValue(it.getCoord());
            EXPECT_LE(std::abs(got - *it), std::ldexp(std::abs(ref), -8) * (1.0 + 1e-6))
                << g->getName() << " " << it.getCoord();
            changed += got != *it;
            ++checked;
        }
    }
    EXPECT_EQ(checked, 2 * 4 * 3 * 42); // 42 of the 64 cells are active
    EXPECT_GT(changed, checked / 2);

    GridSet old = f.written();
    nlohmann::json meta = nlohmann::json::parse(old.metaString(META_SCATTER));
    meta.erase("stored_bits");
    old.setMetaString(META_SCATTER, meta.dump());
    EXPECT_EQ(readScatterFieldMeta(old, false)->storedBits, FIELD_FLOAT_BITS);
    meta["stored_bits"] = 30;
    old.setMetaString(META_SCATTER, meta.dump());
    EXPECT_EQ(errorMessage([&] { readScatterFieldMeta(old, false); }),
              "field.vdb: nebula:scatter has stored_bits 30; expected 4..24 (the significant "
              "bits its moments keep)");
    // A layout this version does not know (DESIGN §5b "Field file format") is refused, never
    // read as these grids.
    meta["stored_bits"] = 8;
    meta["layout"] = "packed";
    old.setMetaString(META_SCATTER, meta.dump());
    EXPECT_EQ(errorMessage([&] { readScatterFieldMeta(old, false); }),
              "field.vdb: nebula:scatter has layout \"packed\", which this version does not read "
              "(it reads fields without \"layout\": one FloatGrid per source, moment and "
              "channel); use a newer nebula, or rerun this nebscatter");
}
