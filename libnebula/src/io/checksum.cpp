// SPDX-License-Identifier: Apache-2.0
#include "nebula/io/checksum.h"

#include <cstdint>
#include <cstring>
#include <type_traits>

namespace nebula {

namespace {

/// A simple, fast 64-bit hash over 8-byte words (multiply-xorshift, as in MurmurHash64A); the
/// tail is zero-padded. Not cryptographic: it detects damage, not tampering.
class Hasher
{
public:
    void add(const void* data, std::size_t bytes)
    {
        const auto* p = static_cast<const unsigned char*>(data);
        while (bytes >= 8) {
            std::uint64_t k;
            std::memcpy(&k, p, 8);
            mix(k);
            p += 8;
            bytes -= 8;
        }
        if (bytes > 0) {
            std::uint64_t k = 0;
            std::memcpy(&k, p, bytes);
            mix(k ^ (std::uint64_t(bytes) << 56));
        }
    }
    template <typename T> void addValue(const T& v) { add(&v, sizeof v); }

    std::string hex() const
    {
        std::uint64_t h = mH;
        h ^= h >> 47;
        h *= M;
        h ^= h >> 47;
        static const char digits[] = "0123456789abcdef";
        std::string out(16, '0');
        for (int i = 15; i >= 0; --i, h >>= 4)
            out[std::size_t(i)] = digits[h & 15];
        return out;
    }

private:
    static constexpr std::uint64_t M = 0xc6a4a7935bd1e995ull;
    void mix(std::uint64_t k)
    {
        k *= M;
        k ^= k >> 47;
        k *= M;
        mH ^= k;
        mH *= M;
    }
    std::uint64_t mH = 0x9e3779b97f4a7c15ull;
};

/// Metadata as name, type and text, skipping the keys OpenVDB itself (re)writes on save
/// ("file_bbox_min", "is_saved_as_half_float", ...) and @p skip.
void addMeta(Hasher& h, const openvdb::MetaMap& meta, const std::string& skip = "")
{
    for (auto it = meta.beginMeta(); it != meta.endMeta(); ++it) {
        const std::string& name = it->first;
        if (name == skip || name.rfind("file_", 0) == 0 || name == "is_saved_as_half_float") {
            continue;
        }
        const std::string type = it->second->typeName(), text = it->second->str();
        for (const std::string* s : {&name, &type, &text}) {
            h.addValue(s->size());
            h.add(s->data(), s->size());
        }
    }
}

template <typename GridT> std::string hashGrid(const GridT& grid)
{
    using TreeT = typename GridT::TreeType;
    using ValueT = typename GridT::ValueType;
    Hasher h;
    addMeta(h, grid); // the name, class, creator and nebula's own grid metadata
    // The map as the images of the origin and the unit vectors (getAffineMap() would invert
    // the matrix, and throw on a singular one).
    const auto& map = *grid.transform().baseMap();
    for (const auto& p : {openvdb::Vec3d(0, 0, 0), openvdb::Vec3d(1, 0, 0), openvdb::Vec3d(0, 1, 0),
                          openvdb::Vec3d(0, 0, 1)}) {
        h.addValue(map.applyMap(p));
    }
    const TreeT& tree = grid.tree();
    h.addValue(tree.background());

    // Tiles of the root and internal nodes: the active ones, then the inactive ones whose
    // value is not the background, each in tree order (detail::forEachTile()).
    for (const bool active : {true, false})
        detail::forEachTile(tree, active,
                            [&](const openvdb::Coord& c, openvdb::Index depth, const ValueT& v) {
                                h.add(c.data(), sizeof(openvdb::Int32) * 3);
                                h.addValue(active ? depth : depth + 100);
                                h.addValue(v);
                            });
    // Leaves: origin, value mask, values.
    for (auto leaf = tree.cbeginLeaf(); leaf; ++leaf) {
        const openvdb::Coord o = leaf->origin();
        h.add(o.data(), sizeof(openvdb::Int32) * 3);
        const auto& mask = leaf->getValueMask();
        for (openvdb::Index w = 0; w < mask.WORD_COUNT; ++w)
            h.addValue(mask.template getWord<openvdb::Index64>(w));
        if constexpr (std::is_same_v<ValueT, bool> || std::is_same_v<ValueT, openvdb::ValueMask>) {
            for (auto v = leaf->cbeginValueAll(); v; ++v)
                h.addValue(char(bool(*v)));
        } else {
            h.add(leaf->buffer().data(), sizeof(ValueT) * TreeT::LeafNodeType::SIZE);
        }
    }
    return h.hex();
}

} // namespace

std::string metadataChecksum(const openvdb::MetaMap& meta, const std::string& skip)
{
    Hasher h;
    addMeta(h, meta, skip);
    return h.hex();
}

std::string gridChecksum(const openvdb::GridBase& grid)
{
    if (grid.saveFloatAsHalf() || !grid.transform().isLinear()) return {};
    std::string sum;
    using Types = openvdb::TypeList<openvdb::FloatGrid, openvdb::DoubleGrid, openvdb::Int32Grid,
                                    openvdb::Int64Grid, openvdb::BoolGrid, openvdb::MaskGrid,
                                    openvdb::Vec3fGrid, openvdb::Vec3dGrid, openvdb::Vec3IGrid>;
    grid.apply<Types>([&sum](const auto& typed) { sum = hashGrid(typed); });
    return sum;
}

} // namespace nebula
