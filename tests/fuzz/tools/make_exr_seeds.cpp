// Writes the EXR seeds of tests/fuzz/corpus/exr (tiny files, so that the fuzzer mutates headers
// and blocks rather than megabytes of pixels): 8x4 RGB HALF (ZIP), RGB FLOAT (no compression),
// Y-only UINT (RLE), a 4x4 tiled RGBA (PIZ) with a data window off the origin, and a cut copy.
//   g++ -std=c++20 -I/usr/include/OpenEXR -I/usr/include/Imath tests/fuzz/tools/make_exr_seeds.cpp \
//       -lOpenEXR -lImath -o /tmp/make_exr_seeds && /tmp/make_exr_seeds tests/fuzz/corpus/exr
#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfOutputFile.h>
#include <ImfTiledOutputFile.h>
#include <half.h>

#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: %s DIR\n", argv[0]);
        return 2;
    }
    const std::string dir = argv[1];
    const int w = 8, h = 4;
    std::vector<half> hv(w * h * 3);
    std::vector<float> fv(w * h * 3);
    std::vector<unsigned> uv(w * h);
    for (int i = 0; i < w * h * 3; ++i) {
        fv[i] = float(i) * 0.25f - (i == 5 ? 10.f : 0.f);  // one negative texel for the sanitiser
        hv[i] = half(fv[i]);
    }
    for (int i = 0; i < w * h; ++i) uv[i] = unsigned(i * 1000);
    {
        Imf::Header header(w, h);
        header.compression() = Imf::ZIP_COMPRESSION;
        for (const char* c : {"R", "G", "B"}) header.channels().insert(c, Imf::Channel(Imf::HALF));
        Imf::OutputFile out((dir + "/rgb_half_zip.exr").c_str(), header);
        Imf::FrameBuffer fb;
        for (int c = 0; c < 3; ++c)
            fb.insert(std::string(1, "RGB"[c]), Imf::Slice(Imf::HALF, reinterpret_cast<char*>(&hv[c]),
                                                           3 * sizeof(half), 3 * sizeof(half) * w));
        out.setFrameBuffer(fb);
        out.writePixels(h);
    }
    {
        Imf::Header header(w, h);
        header.compression() = Imf::NO_COMPRESSION;
        for (const char* c : {"B", "G", "R"}) header.channels().insert(c, Imf::Channel(Imf::FLOAT));
        Imf::OutputFile out((dir + "/rgb_float_raw.exr").c_str(), header);
        Imf::FrameBuffer fb;
        for (int c = 0; c < 3; ++c)
            fb.insert(std::string(1, "RGB"[c]), Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(&fv[c]),
                                                           3 * sizeof(float), 3 * sizeof(float) * w));
        out.setFrameBuffer(fb);
        out.writePixels(h);
    }
    {
        Imf::Header header(w, h);
        header.compression() = Imf::RLE_COMPRESSION;
        header.channels().insert("Y", Imf::Channel(Imf::UINT));
        Imf::OutputFile out((dir + "/y_uint_rle.exr").c_str(), header);
        Imf::FrameBuffer fb;
        fb.insert("Y", Imf::Slice(Imf::UINT, reinterpret_cast<char*>(uv.data()), sizeof(unsigned), sizeof(unsigned) * w));
        out.setFrameBuffer(fb);
        out.writePixels(h);
    }
    {
        const Imath::Box2i display(Imath::V2i(0, 0), Imath::V2i(w - 1, h - 1));
        const Imath::Box2i data(Imath::V2i(2, 1), Imath::V2i(2 + w - 1, 1 + h - 1));
        Imf::Header header(display, data);
        header.compression() = Imf::PIZ_COMPRESSION;
        header.setTileDescription(Imf::TileDescription(4, 4, Imf::ONE_LEVEL));
        for (const char* c : {"A", "B", "G", "R"}) header.channels().insert(c, Imf::Channel(Imf::HALF));
        Imf::TiledOutputFile out((dir + "/rgba_tiled_piz.exr").c_str(), header);
        Imf::FrameBuffer fb;
        char* origin = reinterpret_cast<char*>(hv.data()) - (2 + 1 * w) * 3 * sizeof(half);
        for (int c = 0; c < 3; ++c)
            fb.insert(std::string(1, "RGB"[c]), Imf::Slice(Imf::HALF, origin + c * sizeof(half), 3 * sizeof(half),
                                                           3 * sizeof(half) * w));
        fb.insert("A", Imf::Slice(Imf::HALF, origin, 3 * sizeof(half), 3 * sizeof(half) * w));
        out.setFrameBuffer(fb);
        out.writeTiles(0, out.numXTiles() - 1, 0, out.numYTiles() - 1);
    }
    {
        std::ifstream in(dir + "/rgb_half_zip.exr", std::ios::binary);
        const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
        std::ofstream(dir + "/rgb_half_zip_cut.exr", std::ios::binary) << bytes.substr(0, bytes.size() * 2 / 3);
    }
    return 0;
}
