// SPDX-License-Identifier: Apache-2.0
// NumPy .npy cubes (DESIGN §10): our own header parser (format versions 1.0, 2.0, 3.0; the
// header is a Python dict literal), the data mapped and read plane by plane in either byte
// order and either memory order; cubes written as little-endian float32 in Fortran order.
#include "cube_raw.h"

#include "nebula/core/atomic_file.h"
#include "nebula/core/error.h"
#include "nebula/core/input.h"

#include <fmt/format.h>

#include <cerrno>
#include <cstring>
#include <iostream>

namespace nebula {

namespace {

constexpr char NPY_MAGIC[] = "\x93NUMPY";

/// A cursor over the header's dict literal.
class DictParser
{
public:
    DictParser(std::string_view text, const std::string& name) : mText(text), mName(name) {}

    [[noreturn]] void fail(const std::string& what) const
    {
        throw Error(mName + ": bad .npy header: " + what + " at character " + std::to_string(mPos) +
                    " of \"" + std::string(mText.substr(0, 120)) +
                    (mText.size() > 120 ? "...\"" : "\""));
    }
    void skipSpace()
    {
        while (mPos < mText.size() && (mText[mPos] == ' ' || mText[mPos] == '\t' ||
                                       mText[mPos] == '\n' || mText[mPos] == '\r'))
            ++mPos;
    }
    bool peek(char c)
    {
        skipSpace();
        return mPos < mText.size() && mText[mPos] == c;
    }
    void expect(char c)
    {
        if (!peek(c)) fail(std::string("expected '") + c + "'");
        ++mPos;
    }
    std::string string()
    {
        skipSpace();
        if (mPos >= mText.size() || (mText[mPos] != '\'' && mText[mPos] != '"')) {
            fail("expected a quoted string");
        }
        const char quote = mText[mPos++];
        const std::size_t end = mText.find(quote, mPos);
        if (end == std::string_view::npos) fail("unterminated string");
        std::string s(mText.substr(mPos, end - mPos));
        if (s.find('\\') != std::string::npos) fail("escapes in a string");
        mPos = end + 1;
        return s;
    }
    bool boolean()
    {
        skipSpace();
        for (const auto& [word, value] : {std::pair{"True", true}, std::pair{"False", false}}) {
            const std::size_t n = std::strlen(word);
            if (mText.substr(mPos, n) == word) {
                mPos += n;
                return value;
            }
        }
        fail("expected True or False");
    }
    std::vector<std::int64_t> tuple()
    {
        expect('(');
        std::vector<std::int64_t> v;
        while (!peek(')')) {
            skipSpace();
            std::int64_t n = 0;
            std::size_t digits = 0;
            while (mPos < mText.size() && mText[mPos] >= '0' && mText[mPos] <= '9') {
                if (n > (std::int64_t(1) << 56)) fail("an axis length beyond 2^56");
                n = n * 10 + (mText[mPos++] - '0');
                ++digits;
            }
            if (mPos < mText.size() && mText[mPos] == 'L') ++mPos; // Python 2's long
            if (digits == 0) fail("expected a non-negative integer in the shape");
            if (v.size() >= 32) fail("more than 32 axes");
            v.push_back(n);
            if (!peek(',')) break;
            ++mPos;
        }
        expect(')');
        return v;
    }
    bool atEnd()
    {
        skipSpace();
        return mPos == mText.size();
    }

private:
    std::string_view mText;
    const std::string& mName;
    std::size_t mPos = 0;
};

/// Parses a dtype descr ("<f4") into @p h.
void parseDescr(const std::string& d, NpyHeader& h, const std::string& name)
{
    const auto bad = [&](const std::string& why) {
        throw Error(name + ": dtype '" + d + "' " + why +
                    " (expected floats <f4 >f4 <f8 >f8, or integers such as <i2 |u1)");
    };
    if (d.size() < 2) bad("is not a dtype");
    const char order = d[0];
    if (order != '<' && order != '>' && order != '|' && order != '=') bad("has no byte order");
    const char kind = d[1];
    if (kind == 'O') {
        throw Error(name + ": dtype '" + d +
                    "' is an object array (pickled Python objects), which cannot be read as a "
                    "cube; save a numeric array (e.g. a.astype('f4'))");
    }
    if (kind != 'f' && kind != 'i' && kind != 'u' && kind != 'b') bad("is not a number type");
    const std::string size = d.substr(2);
    if (size.empty() || size.size() > 2 ||
        size.find_first_not_of("0123456789") != std::string::npos) {
        bad("has no item size");
    }
    const int bytes = std::stoi(size);
    const bool ok = kind == 'f'   ? (bytes == 4 || bytes == 8)
                    : kind == 'b' ? bytes == 1
                                  : (bytes == 1 || bytes == 2 || bytes == 4 || bytes == 8);
    if (!ok) bad("has an unsupported size");
    if (order == '|' && bytes != 1) bad("has no byte order but more than one byte");
    h.byteOrder = order == '=' ? '<' : order; // '=' is native: little-endian here
    h.kind = kind;
    h.itemSize = bytes;
}

} // namespace

NpyHeader parseNpyHeader(std::string_view bytes, const std::string& name)
{
    if (bytes.size() < 10 || bytes.substr(0, 6) != std::string_view(NPY_MAGIC, 6)) {
        throw Error(name + ": not a .npy file (no \\x93NUMPY magic)");
    }
    NpyHeader h;
    h.major = static_cast<unsigned char>(bytes[6]);
    h.minor = static_cast<unsigned char>(bytes[7]);
    if ((h.major != 1 && h.major != 2 && h.major != 3) || h.minor != 0) {
        throw Error(name + fmt::format(": .npy format version {}.{}, expected 1.0, 2.0 or 3.0",
                                       h.major, h.minor));
    }
    std::size_t length = 0, start = 0;
    const auto byte = [&](std::size_t i) {
        return std::size_t(static_cast<unsigned char>(bytes[i]));
    };
    if (h.major == 1) {
        length = byte(8) | byte(9) << 8;
        start = 10;
    } else {
        if (bytes.size() < 12) throw Error(name + ": truncated .npy header");
        length = byte(8) | byte(9) << 8 | byte(10) << 16 | byte(11) << 24;
        start = 12;
    }
    if (length > MAX_NPY_HEADER_BYTES) {
        throw Error(name + fmt::format(": .npy header of {} bytes, more than the {} read", length,
                                       MAX_NPY_HEADER_BYTES));
    }
    if (bytes.size() < start + length) {
        throw Error(name + fmt::format(": truncated: the .npy header says {} bytes, the file "
                                       "has {} after the magic",
                                       length, bytes.size() - start));
    }
    h.dataOffset = start + length;
    DictParser p(bytes.substr(start, length), name);
    p.expect('{');
    bool descr = false, order = false, shape = false;
    while (!p.peek('}')) {
        const std::string key = p.string();
        p.expect(':');
        if (key == "descr" && !descr) {
            if (p.peek('[')) {
                throw Error(name + ": a structured dtype (record array), expected numbers");
            }
            parseDescr(p.string(), h, name);
            descr = true;
        } else if (key == "fortran_order" && !order) {
            h.fortranOrder = p.boolean();
            order = true;
        } else if (key == "shape" && !shape) {
            h.shape = p.tuple();
            shape = true;
        } else {
            p.fail("unexpected or repeated key '" + key + "'");
        }
        if (!p.peek(',')) break;
        p.expect(',');
    }
    p.expect('}');
    if (!descr || !order || !shape) p.fail("missing 'descr', 'fortran_order' or 'shape'");
    // The total size in bytes must be a sane number.
    double total = double(h.itemSize);
    for (auto n : h.shape)
        total *= double(n);
    if (total > 9.0e18) throw Error(name + ": the .npy header's shape is impossibly large");
    return h;
}

std::string npyHeader(const std::vector<std::int64_t>& shape, bool fortranOrder)
{
    std::string dict = std::string("{'descr': '<f4', 'fortran_order': ") +
                       (fortranOrder ? "True" : "False") + ", 'shape': (";
    for (std::size_t i = 0; i < shape.size(); ++i)
        dict += (i ? ", " : "") + std::to_string(shape[i]);
    dict += shape.size() == 1 ? ",), }" : "), }";
    const bool v2 = dict.size() + 12 > 65535;
    const std::size_t prefix = v2 ? 12 : 10;
    std::size_t total = prefix + dict.size() + 1;
    total = (total + 63) / 64 * 64;
    dict.append(total - prefix - dict.size() - 1, ' ');
    dict += '\n';
    std::string out(NPY_MAGIC, 6);
    out += char(v2 ? 2 : 1);
    out += char(0);
    const std::size_t n = dict.size();
    out += char(n & 0xff);
    out += char((n >> 8) & 0xff);
    if (v2) {
        out += char((n >> 16) & 0xff);
        out += char((n >> 24) & 0xff);
    }
    return out + dict;
}

namespace detail {

namespace {

/// One element at @p p as a double.
double npyValue(const unsigned char* p, const NpyHeader& h)
{
    unsigned char b[8];
    const bool swap = h.byteOrder == '>';
    for (int i = 0; i < h.itemSize; ++i)
        b[i] = swap ? p[h.itemSize - 1 - i] : p[i];
    switch (h.kind) {
    case 'f':
        if (h.itemSize == 4) {
            float f;
            std::memcpy(&f, b, 4);
            return f;
        } else {
            double d;
            std::memcpy(&d, b, 8);
            return d;
        }
    case 'b': return b[0] ? 1.0 : 0.0;
    case 'u': {
        std::uint64_t u = 0;
        for (int i = h.itemSize; i-- > 0;)
            u = u << 8 | b[i];
        return double(u);
    }
    default: {
        std::uint64_t u = 0;
        for (int i = h.itemSize; i-- > 0;)
            u = u << 8 | b[i];
        const int shift = 64 - 8 * h.itemSize;
        return double(std::int64_t(u << shift) >> shift); // sign-extended
    }
    }
}

class NpyArray final : public RawArray
{
public:
    NpyArray(InputBytes bytes, NpyHeader header) : mBytes(std::move(bytes)), mH(std::move(header))
    {}
    std::vector<std::int64_t> shape() const override { return mH.shape; }
    bool firstFastest() const override { return mH.fortranOrder; }
    void readBlock(const std::vector<std::int64_t>& fixed, double* out) override
    {
        const std::size_t nd = mH.shape.size();
        // Storage axes, slowest first.
        std::vector<std::size_t> storage(nd);
        for (std::size_t i = 0; i < nd; ++i)
            storage[i] = mH.fortranOrder ? nd - 1 - i : i;
        std::int64_t count = 1;
        for (std::size_t i = fixed.size(); i < nd; ++i)
            count *= mH.shape[storage[i]];
        std::int64_t offset = 0, stride = count;
        for (std::size_t f = fixed.size(); f-- > 0;) {
            offset += fixed[f] * stride;
            stride *= mH.shape[storage[f]];
        }
        const std::size_t begin = mH.dataOffset + std::size_t(offset) * std::size_t(mH.itemSize);
        const auto* p = reinterpret_cast<const unsigned char*>(mBytes.view().data()) + begin;
        if (mH.kind == 'f' && mH.itemSize == 4 && mH.byteOrder == '<') {
            for (std::int64_t i = 0; i < count; ++i) {
                float f;
                std::memcpy(&f, p + 4 * i, 4);
                out[i] = f;
            }
        } else {
            for (std::int64_t i = 0; i < count; ++i)
                out[i] = npyValue(p + std::size_t(i) * std::size_t(mH.itemSize), mH);
        }
        // Read once: the mapped pages need not stay.
        mBytes.release(begin, begin + std::size_t(count) * std::size_t(mH.itemSize));
    }

private:
    InputBytes mBytes;
    NpyHeader mH;
};

} // namespace

std::unique_ptr<CubeSource> openNpyCube(const std::string& path, const CubeSelect& select)
{
    InputSpec spec;
    spec.option = select.option;
    spec.format = "a .npy file";
    spec.limit = MAX_GRID_INPUT_BYTES;
    spec.checkMemory = true;
    spec.head = [](std::string_view head, bool atEnd, const std::string& source) {
        if (head.size() < 6 && !atEnd) return false;
        if (head.substr(0, 6) != std::string_view(NPY_MAGIC, 6)) {
            throw Error(source + ": not a .npy file (no \\x93NUMPY magic)");
        }
        return true;
    };
    InputBytes bytes = mapInput(path, spec);
    const NpyHeader h = parseNpyHeader(bytes.view(), path);
    CubeInfo info;
    info.name = path;
    checkCubeShape(h.shape, select.component, path);
    double need = double(h.itemSize);
    for (auto n : h.shape)
        need *= double(n);
    const double have = double(bytes.view().size()) - double(h.dataOffset);
    if (need > have) {
        throw Error(path + fmt::format(": truncated: the header says {} bytes of data, the file "
                                       "holds {}",
                                       need, have));
    }
    auto array = std::make_unique<NpyArray>(std::move(bytes), h);
    return arrayCube(std::move(array), std::move(info), select.component);
}

void writeNpyCube(const std::string& path, const CubeHeader& h, const PlaneFunction& plane)
{
    const std::int64_t nx = h.dims[0], ny = h.dims[1], nz = h.dims[2];
    const std::string header = npyHeader({nx, ny, nz}, true);
    std::vector<float> buf(std::size_t(nx * ny));
    const auto writeAll = [&](std::ostream& out) {
        out.write(header.data(), std::streamsize(header.size()));
        for (std::int64_t k = 0; k < nz; ++k) {
            plane(PlaneOrder{2, 0, 1}, k, buf.data());
            out.write(reinterpret_cast<const char*>(buf.data()),
                      std::streamsize(buf.size() * sizeof(float)));
        }
    };
    if (path == "-") {
        writeAll(std::cout);
        std::cout.flush();
        if (!std::cout)
            throw Error("<stdout>: write failed (" + std::string(std::strerror(errno)) + ")");
        return;
    }
    AtomicFile file(path);
    writeAll(file.stream());
    file.commit();
}

const CubeFormat& npyCubeFormat()
{
    static const CubeFormat format = [] {
        CubeFormat f;
        f.name = "npy";
        f.title = "NumPy .npy";
        f.doc = ".npy";
        f.hint = ".npy";
        f.endings = {".npy"};
        f.open = openNpyCube;
        f.fileFormat = FileFormat::Npy;
        f.write = [](const std::string& path, const CubeHeader& header, const std::string&,
                     const PlaneFunction& plane) { writeNpyCube(path, header, plane); };
        f.writerMemory = [](const std::array<std::int64_t, 3>& dims, double) {
            // Streamed: one z plane at a time.
            return WriterMemory{4.0 * double(dims[0]) * double(dims[1]),
                                "one z plane of the .npy stream"};
        };
        return f;
    }();
    return format;
}

} // namespace detail
} // namespace nebula
