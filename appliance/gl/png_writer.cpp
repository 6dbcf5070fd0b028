#include "appliance/gl/png_writer.hpp"

#include <zlib.h>

#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>

#include "appliance/core/atomic_file.hpp"
#include "appliance/core/errors.hpp"

namespace glint::gl {

namespace {

void put_u32(std::vector<std::uint8_t>& out, std::uint32_t v) {
    for (int s = 24; s >= 0; s -= 8) out.push_back(std::uint8_t(v >> s));
}

std::uint32_t get_u32(const std::uint8_t* p) {
    return std::uint32_t(p[0]) << 24 | std::uint32_t(p[1]) << 16 | std::uint32_t(p[2]) << 8 | p[3];
}

void put_chunk(std::vector<std::uint8_t>& out, const char* type, const std::vector<std::uint8_t>& data) {
    put_u32(out, std::uint32_t(data.size()));
    const std::size_t body = out.size();
    out.insert(out.end(), type, type + 4);
    out.insert(out.end(), data.begin(), data.end());
    put_u32(out, std::uint32_t(crc32(0, out.data() + body, uInt(out.size() - body))));
}

int paeth(int a, int b, int c) {
    const int p = a + b - c, pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
    return pa <= pb && pa <= pc ? a : pb <= pc ? b : c;
}

}  // namespace

std::vector<std::uint8_t> encode_png(const RgbImage& image) {
    if (image.width <= 0 || image.height <= 0 ||
        image.pixels.size() != std::size_t(image.width) * std::size_t(image.height) * 3)
        throw RuntimeError("PNG: the image's size does not match its pixels");
    const std::size_t row = std::size_t(image.width) * 3;
    std::vector<std::uint8_t> raw;
    raw.reserve((row + 1) * std::size_t(image.height));
    for (int y = 0; y < image.height; ++y) {
        raw.push_back(0);  // filter: none (screenshots compress well enough, and it is fast)
        raw.insert(raw.end(), image.pixels.begin() + std::ptrdiff_t(row * std::size_t(y)),
                   image.pixels.begin() + std::ptrdiff_t(row * std::size_t(y + 1)));
    }
    uLongf size = compressBound(uLong(raw.size()));
    std::vector<std::uint8_t> z(size);
    if (compress2(z.data(), &size, raw.data(), uLong(raw.size()), 6) != Z_OK) throw RuntimeError("PNG: zlib failed");
    z.resize(size);
    std::vector<std::uint8_t> out{0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    std::vector<std::uint8_t> header;
    put_u32(header, std::uint32_t(image.width));
    put_u32(header, std::uint32_t(image.height));
    header.insert(header.end(), {8, 2, 0, 0, 0});  // 8 bits, RGB, deflate, adaptive filters, no interlace
    put_chunk(out, "IHDR", header);
    put_chunk(out, "IDAT", z);
    put_chunk(out, "IEND", {});
    return out;
}

void save_png(const std::filesystem::path& path, const RgbImage& image) {
    const std::vector<std::uint8_t> bytes = encode_png(image);
    write_text_atomically(path, std::string_view(reinterpret_cast<const char*>(bytes.data()), bytes.size()));
}

RgbImage load_png(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw InputError(path.string() + ": cannot read");
    const std::vector<std::uint8_t> b((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto bad = [&](const std::string& why) { return InputError(path.string() + ": " + why); };
    static const std::uint8_t signature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    if (b.size() < 8 || !std::equal(signature, signature + 8, b.begin())) throw bad("not a PNG file");
    RgbImage image;
    std::vector<std::uint8_t> z;
    bool header = false, end = false;
    for (std::size_t p = 8; p + 12 <= b.size() && !end;) {
        const std::uint32_t length = get_u32(&b[p]);
        if (length > b.size() - p - 12) throw bad("truncated chunk");
        const std::string type(reinterpret_cast<const char*>(&b[p + 4]), 4);
        const std::uint8_t* data = &b[p + 8];
        if (get_u32(data + length) != std::uint32_t(crc32(0, &b[p + 4], uInt(length + 4))))
            throw bad("chunk " + type + " fails its CRC");
        if (type == "IHDR") {
            if (length != 13) throw bad("bad IHDR");
            image.width = int(get_u32(data));
            image.height = int(get_u32(data + 4));
            if (data[8] != 8 || data[9] != 2 || data[12] != 0)
                throw bad("only 8-bit RGB PNGs without interlacing are read");
            if (image.width <= 0 || image.height <= 0 || image.width > 16384 || image.height > 16384)
                throw bad("image size out of range");
            header = true;
        } else if (type == "IDAT") {
            z.insert(z.end(), data, data + length);
        } else if (type == "IEND") {
            end = true;
        }
        p += 12 + length;
    }
    if (!header || !end) throw bad(header ? "no IEND (truncated)" : "no IHDR");
    const std::size_t row = std::size_t(image.width) * 3;
    std::vector<std::uint8_t> raw((row + 1) * std::size_t(image.height));
    uLongf size = uLongf(raw.size());
    if (uncompress(raw.data(), &size, z.data(), uLong(z.size())) != Z_OK || size != raw.size())
        throw bad("image data is corrupt or truncated");
    image.pixels.resize(row * std::size_t(image.height));
    for (int y = 0; y < image.height; ++y) {
        const std::uint8_t filter = raw[std::size_t(y) * (row + 1)];
        const std::uint8_t* src = &raw[std::size_t(y) * (row + 1) + 1];
        std::uint8_t* dst = &image.pixels[std::size_t(y) * row];
        const std::uint8_t* up = y > 0 ? dst - row : nullptr;
        for (std::size_t x = 0; x < row; ++x) {
            const int a = x >= 3 ? dst[x - 3] : 0, u = up ? up[x] : 0, c = (x >= 3 && up) ? up[x - 3] : 0;
            int v = src[x];
            switch (filter) {
                case 0: break;
                case 1: v += a; break;
                case 2: v += u; break;
                case 3: v += (a + u) / 2; break;
                case 4: v += paeth(a, u, c); break;
                default: throw bad("unknown row filter " + std::to_string(filter));
            }
            dst[x] = std::uint8_t(v);
        }
    }
    return image;
}

}  // namespace glint::gl
