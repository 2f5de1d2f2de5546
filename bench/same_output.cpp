// SPDX-License-Identifier: Apache-2.0
/// @file same_output.cpp
/// Whether two nebula outputs hold the same data, bit for bit: the check behind
/// bench/before_after.sh (a refactoring must not change a single value).
///
///     build/bench/same_output A B
///
/// .vdb: the same grids in the same order, each with the same name, type, transform, grid
/// metadata, active topology and values (compared as bits), and the same file metadata apart
/// from nebula:history and nebula:version, nebscatter's run time (nebula:scatter's "seconds")
/// and the metadata's checksum that covers it (the file UUID is not compared: OpenVDB writes a
/// new one every time). .exr: the same size, channels (beauty, layers, single channels) as
/// bits, and attributes apart from nebula:history and nebula:version; an attribute holding
/// JSON is compared as JSON, numbers to 6 significant digits (older files wrote them with 6).
/// .fits: HDU by HDU, the same header cards apart from HISTORY, DATE, ORIGIN (the version) and
/// CHECKSUM (which covers them), and the same data bytes. Anything else: the same bytes. Prints
/// "same" or the first difference; exit 0 if the same, 1 if not, 2 on bad use.

#include "nebula/core/error.h"
#include "nebula/io/grid_io.h"
#include "nebula/io/image.h"

#include <nlohmann/json.hpp>
#include <openvdb/openvdb.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <iterator>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace {

const std::set<std::string> IGNORED_META = {"nebula:history", "nebula:version"};

bool endsWith(const std::string& s, const std::string& suffix)
{
    return s.size() >= suffix.size() &&
           s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

bool sameBits(const float* a, const float* b, std::size_t n)
{
    return std::memcmp(a, b, n * sizeof(float)) == 0;
}

/// File metadata @p value of @p key without the members that change from run to run: the
/// scattered-light field's run time ("seconds") and, in nebula:checksums, the checksum of the
/// metadata that holds it (every other key is compared itself).
std::string comparedMeta(const std::string& key, const std::string& value)
{
    const char* member = key == "nebula:scatter" || key == "nebula:scatter_spectral" ? "seconds"
                         : key == "nebula:checksums"                                 ? "metadata"
                                                                                     : nullptr;
    if (!member) return value;
    auto json = nlohmann::json::parse(value, nullptr, false);
    if (json.is_discarded() || !json.is_object()) return value;
    json.erase(member);
    return json.dump();
}

std::string metaText(const openvdb::MetaMap& meta, bool fileLevel)
{
    std::ostringstream out;
    for (auto it = meta.beginMeta(); it != meta.endMeta(); ++it) {
        if (fileLevel && IGNORED_META.count(it->first)) continue;
        const std::string value = it->second->str();
        out << it->first << "=" << (fileLevel ? comparedMeta(it->first, value) : value) << "\n";
    }
    return out.str();
}

template <typename GridT> std::string compareValues(const GridT& a, const GridT& b)
{
    if (a.activeVoxelCount() != b.activeVoxelCount()) return "active voxel counts differ";
    if (!a.tree().hasSameTopology(b.tree())) return "active topologies differ";
    auto acc = b.getConstAccessor();
    for (auto it = a.cbeginValueOn(); it; ++it) {
        const auto va = *it, vb = acc.getValue(it.getCoord());
        if (std::memcmp(&va, &vb, sizeof(va)) != 0) {
            std::ostringstream out;
            out << "values differ at " << it.getCoord();
            return out.str();
        }
    }
    const auto ba = a.background(), bb = b.background();
    if (std::memcmp(&ba, &bb, sizeof(ba)) != 0) return "backgrounds differ";
    return "";
}

std::string compareVdb(const std::string& pa, const std::string& pb)
{
    const auto a = nebula::readGrids(pa), b = nebula::readGrids(pb);
    if (metaText(a.meta, true) != metaText(b.meta, true)) {
        return "file metadata differs:\n" + metaText(a.meta, true) + "---\n" +
               metaText(b.meta, true);
    }
    if (a.grids.size() != b.grids.size()) return "numbers of grids differ";
    for (std::size_t i = 0; i < a.grids.size(); ++i) {
        const auto& ga = a.grids[i];
        const auto& gb = b.grids[i];
        const std::string name = "grid \"" + ga->getName() + "\": ";
        if (ga->getName() != gb->getName()) return "grid " + std::to_string(i) + ": names differ";
        if (ga->type() != gb->type()) return name + "types differ";
        if (ga->transform() != gb->transform()) return name + "transforms differ";
        if (metaText(*ga, false) != metaText(*gb, false)) return name + "grid metadata differs";
        std::string diff;
        if (auto fa = openvdb::gridPtrCast<openvdb::FloatGrid>(ga)) {
            diff = compareValues(*fa, *openvdb::gridPtrCast<openvdb::FloatGrid>(gb));
        } else if (auto va = openvdb::gridPtrCast<openvdb::Vec3fGrid>(ga)) {
            diff = compareValues(*va, *openvdb::gridPtrCast<openvdb::Vec3fGrid>(gb));
        } else {
            return name + "type " + ga->type() + " not compared";
        }
        if (!diff.empty()) return name + diff;
    }
    return "";
}

/// Whether JSON values @p a and @p b are equal, numbers to 6 significant digits.
bool sameJson(const nlohmann::json& a, const nlohmann::json& b)
{
    if (a.is_number() && b.is_number()) {
        const double x = a.get<double>(), y = b.get<double>();
        return std::abs(x - y) <= 5e-6 * std::max(std::abs(x), std::abs(y));
    }
    if (a.type() != b.type() || a.size() != b.size()) return false;
    if (a.is_array()) {
        for (std::size_t i = 0; i < a.size(); ++i) {
            if (!sameJson(a[i], b[i])) return false;
        }
        return true;
    }
    if (a.is_object()) {
        for (auto it = a.begin(); it != a.end(); ++it) {
            if (!b.contains(it.key()) || !sameJson(it.value(), b.at(it.key()))) return false;
        }
        return true;
    }
    return a == b;
}

bool sameAttribute(const std::string& a, const std::string& b)
{
    if (a == b) return true;
    const auto ja = nlohmann::json::parse(a, nullptr, false);
    const auto jb = nlohmann::json::parse(b, nullptr, false);
    return !ja.is_discarded() && !jb.is_discarded() && sameJson(ja, jb);
}

std::string compareExr(const std::string& pa, const std::string& pb)
{
    std::map<std::string, std::string> ma, mb;
    const auto a = nebula::readExr(pa, &ma), b = nebula::readExr(pb, &mb);
    for (const auto& key : IGNORED_META) {
        ma.erase(key);
        mb.erase(key);
    }
    if (a.width != b.width || a.height != b.height) return "sizes differ";
    for (const auto& [key, value] : ma) {
        if (!mb.count(key)) return "attribute " + key + " missing in " + pb;
        if (!sameAttribute(value, mb.at(key))) {
            return "attribute " + key + " differs: " + value + " | " + mb.at(key);
        }
    }
    for (const auto& [key, value] : mb) {
        if (!ma.count(key)) return "attribute " + key + " missing in " + pa;
    }
    if (!sameBits(a.rgba.data(), b.rgba.data(), a.rgba.size())) return "R,G,B,A differ";
    if (a.layers.size() != b.layers.size()) return "numbers of layers differ";
    for (std::size_t i = 0; i < a.layers.size(); ++i) {
        if (a.layers[i].name != b.layers[i].name) return "layer names differ";
        if (!sameBits(a.layers[i].rgb.data(), b.layers[i].rgb.data(), a.layers[i].rgb.size())) {
            return "layer " + a.layers[i].name + " differs";
        }
    }
    if (a.channels.size() != b.channels.size()) return "numbers of channels differ";
    for (std::size_t i = 0; i < a.channels.size(); ++i) {
        if (a.channels[i].name != b.channels[i].name ||
            !sameBits(a.channels[i].values.data(), b.channels[i].values.data(),
                      a.channels[i].values.size())) {
            return "channel " + a.channels[i].name + " differs";
        }
    }
    return "";
}

std::string compareBytes(const std::string& pa, const std::string& pb)
{
    std::ifstream fa(pa, std::ios::binary), fb(pb, std::ios::binary);
    if (!fa || !fb) throw nebula::Error("cannot open " + std::string(!fa ? pa : pb));
    const std::string a((std::istreambuf_iterator<char>(fa)), {});
    const std::string b((std::istreambuf_iterator<char>(fb)), {});
    return a == b ? "" : "bytes differ";
}

/// One HDU of a FITS file: its header cards (those compared) and its data bytes.
struct FitsHdu
{
    std::vector<std::string> cards;
    std::string data;
};

/// The cards whose values change from run to run or with the version, not with the result.
bool ignoredFitsCard(const std::string& keyword)
{
    return keyword == "HISTORY" || keyword == "DATE" || keyword == "ORIGIN" ||
           keyword == "CHECKSUM";
}

/// The integer value of card @p card (a mandatory keyword: BITPIX, NAXISn, PCOUNT, GCOUNT).
long long fitsInteger(const std::string& card, const std::string& path)
{
    try {
        return std::stoll(card.substr(10, 20));
    } catch (const std::exception&) {
        throw nebula::Error(path + ": not an integer in the FITS card \"" + card + "\"");
    }
}

/// The HDUs of the FITS file @p path: the 80-character cards of each header up to END, then
/// |BITPIX| / 8 x GCOUNT x (PCOUNT + NAXIS1 x ... x NAXISn) data bytes, each padded to 2880.
std::vector<FitsHdu> readFitsHdus(const std::string& path)
{
    std::ifstream in(path, std::ios::binary);
    if (!in) throw nebula::Error("cannot open " + path);
    const std::string bytes((std::istreambuf_iterator<char>(in)), {});
    const std::size_t BLOCK = 2880, CARD = 80;
    std::vector<FitsHdu> hdus;
    std::size_t at = 0;
    while (at < bytes.size()) {
        FitsHdu hdu;
        long long bitpix = 0, naxis = 0, pcount = 0, gcount = 1, elements = 1;
        for (bool end = false; !end; at += CARD) {
            if (at + CARD > bytes.size()) throw nebula::Error(path + ": a FITS header ends early");
            const std::string card = bytes.substr(at, CARD);
            std::string key = card.substr(0, 8); // the keyword: columns 1-8, blank padded
            key.erase(key.find_last_not_of(' ') + 1);
            end = key == "END";
            if (key == "BITPIX") bitpix = fitsInteger(card, path);
            if (key == "NAXIS") naxis = fitsInteger(card, path);
            if (key.size() > 5 && key.compare(0, 5, "NAXIS") == 0)
                elements *= fitsInteger(card, path);
            if (key == "PCOUNT") pcount = fitsInteger(card, path);
            if (key == "GCOUNT") gcount = fitsInteger(card, path);
            if (!ignoredFitsCard(key) && card.find_first_not_of(' ') != std::string::npos) {
                hdu.cards.push_back(card);
            }
        }
        at = (at + BLOCK - 1) / BLOCK * BLOCK;
        const long long size =
            naxis == 0 && pcount == 0 ? 0 : std::abs(bitpix) / 8 * gcount * (pcount + elements);
        if (size < 0 || at + static_cast<std::size_t>(size) > bytes.size()) {
            throw nebula::Error(path + ": FITS data shorter than its header says");
        }
        const std::size_t padded = (static_cast<std::size_t>(size) + BLOCK - 1) / BLOCK * BLOCK;
        hdu.data = bytes.substr(at, padded); // with its padding: every byte is compared
        at += padded;
        hdus.push_back(std::move(hdu));
    }
    return hdus;
}

std::string compareFits(const std::string& pa, const std::string& pb)
{
    const auto a = readFitsHdus(pa), b = readFitsHdus(pb);
    if (a.size() != b.size()) return "numbers of HDUs differ";
    for (std::size_t i = 0; i < a.size(); ++i) {
        const std::string hdu = "HDU " + std::to_string(i) + ": ";
        for (std::size_t c = 0; c < std::min(a[i].cards.size(), b[i].cards.size()); ++c) {
            if (a[i].cards[c] != b[i].cards[c]) {
                return hdu + "cards differ: \"" + a[i].cards[c] + "\" | \"" + b[i].cards[c] + "\"";
            }
        }
        if (a[i].cards.size() != b[i].cards.size()) return hdu + "numbers of cards differ";
        if (a[i].data != b[i].data) return hdu + "data differ";
    }
    return "";
}

} // namespace

int main(int argc, char** argv)
{
    if (argc != 3) {
        std::fprintf(stderr, "usage: same_output A B\n");
        return 2;
    }
    const std::string a = argv[1], b = argv[2];
    try {
        openvdb::initialize();
        const std::string diff = endsWith(a, ".vdb")    ? compareVdb(a, b)
                                 : endsWith(a, ".exr")  ? compareExr(a, b)
                                 : endsWith(a, ".fits") ? compareFits(a, b)
                                                        : compareBytes(a, b);
        if (diff.empty()) {
            std::printf("same       %s\n", a.c_str());
            return 0;
        }
        std::printf("DIFFERENT  %s: %s\n", a.c_str(), diff.c_str());
        return 1;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "same_output: error: %s\n", e.what());
        return 2;
    }
}
