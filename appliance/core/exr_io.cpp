// OpenEXR I/O. Every OpenEXR exception becomes an InputError that names the file.
#include "appliance/core/exr_io.hpp"

#include <ImfChannelList.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfInputFile.h>
#include <ImfOutputFile.h>
#include <ImfThreading.h>

#include <limits>
#include <string>

#include "appliance/core/atomic_file.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/parallel.hpp"

namespace glint {
namespace {

// Guards against absurd headers before we allocate: 1 Gi texels is far beyond any
// environment map the appliance will see.
constexpr long long kMaxTexels = 1LL << 30;
// No EXR compression holds more than this many decoded bytes per byte of file (deflate's limit is
// about 1032, RLE's 64; real photographs compress 2-10x): a header claiming more is damaged, and
// is refused before its image is allocated (a 469-byte RLE file claimed 67108872x4 texels, 3 GiB).
constexpr long long kMaxCompressionRatio = 4096;

}  // namespace

LoadedExr load_exr(const std::filesystem::path& path) {
    std::error_code ec;
    if (!std::filesystem::is_regular_file(path, ec))
        throw InputError("input " + path.string() + " does not exist or is not a file");
    LoadedExr out;
    try {
        // OpenEXR decodes line blocks on its own thread pool: one thread per core.
        Imf::InputFile file(path.c_str(), hardware_threads());
        const Imath::Box2i dw = file.header().dataWindow();
        const long long w = (long long)dw.max.x - dw.min.x + 1;
        const long long h = (long long)dw.max.y - dw.min.y + 1;
        if (w <= 0 || h <= 0 || w * h > kMaxTexels)
            throw InputError("input " + path.string() + " has an unusable size " +
                             std::to_string(w) + "x" + std::to_string(h));
        const Imf::ChannelList& channels = file.header().channels();
        const bool rgb = channels.findChannel("R") && channels.findChannel("G") &&
                         channels.findChannel("B");
        const bool y = channels.findChannel("Y") != nullptr;
        if (!rgb && !y)
            throw InputError("input " + path.string() +
                             " has neither R, G, B nor Y channels");
        out.luminance_only = !rgb;
        // Before the image is allocated: a header that names a huge data window over a short file
        // (16 KB asking for 12 GiB; tests/fuzz/corpus/exr/oom-truncated-huge.exr) is refused
        // without zero-filling memory for it.
        if (!file.isComplete())
            throw InputError("input " + path.string() + " is truncated (missing scanlines)");
        long long bytes_per_texel = 0;
        for (Imf::ChannelList::ConstIterator c = channels.begin(); c != channels.end(); ++c)
            bytes_per_texel += c.channel().type == Imf::HALF ? 2 : 4;
        const std::uintmax_t file_bytes = std::filesystem::file_size(path, ec);
        if (!ec && (long double)(w * h) * (long double)bytes_per_texel >
                       (long double)file_bytes * (long double)kMaxCompressionRatio)
            throw InputError("input " + path.string() + " is damaged: its header claims " + std::to_string(w) + "x" +
                             std::to_string(h) + " texels in a file of " + std::to_string(file_bytes) +
                             " bytes, more than any EXR compression holds");
        out.image = HdrImage(int(w), int(h));
        float* base = out.image.data().data();
        // Slices address the data window from its origin; x/y strides in bytes.
        const std::size_t xs = 3 * sizeof(float);
        const std::size_t ys = xs * std::size_t(w);
        char* origin = reinterpret_cast<char*>(base) - std::ptrdiff_t(dw.min.x) * std::ptrdiff_t(xs) -
                       std::ptrdiff_t(dw.min.y) * std::ptrdiff_t(ys);
        Imf::FrameBuffer fb;
        const char* names[3] = {"R", "G", "B"};
        // A frame buffer holds one slice per channel name, so Y is read into R
        // and copied to G and B afterwards.
        for (int c = 0; c < (rgb ? 3 : 1); ++c)
            fb.insert(rgb ? names[c] : "Y",
                      Imf::Slice(Imf::FLOAT, origin + c * sizeof(float), xs, ys, 1, 1, 0.0));
        file.setFrameBuffer(fb);
        file.readPixels(dw.min.y, dw.max.y);
        if (!rgb)
            for (std::size_t k = 0; k < out.image.data().size(); k += 3)
                base[k + 1] = base[k + 2] = base[k];
    } catch (const InputError&) {
        throw;
    } catch (const std::exception& e) {
        throw InputError("input " + path.string() + " is not a readable OpenEXR file: " +
                         e.what());
    }
    out.sanitised = sanitise(out.image);
    return out;
}

void save_exr(const std::filesystem::path& path, const HdrImage& image, ExrCompression compression) {
    if (image.empty()) throw RuntimeError("refusing to save an empty image to " + path.string());
    write_file_atomically(path, [&](const std::filesystem::path& tmp) {
        try {
            Imf::Header header(image.width(), image.height());
            header.compression() =
                compression == ExrCompression::Zip ? Imf::ZIP_COMPRESSION : Imf::NO_COMPRESSION;
            // zlib's fastest level: float radiance compresses little at any level, and the
            // default level (6) took most of a large write's time.
            header.zipCompressionLevel() = 1;
            for (const char* name : {"R", "G", "B"})
                header.channels().insert(name, Imf::Channel(Imf::FLOAT));
            Imf::OutputFile file(tmp.c_str(), header, hardware_threads());  // encodes on its pool too
            Imf::FrameBuffer fb;
            char* base = const_cast<char*>(reinterpret_cast<const char*>(image.data().data()));
            const std::size_t xs = 3 * sizeof(float);
            const std::size_t ys = xs * std::size_t(image.width());
            const char* names[3] = {"R", "G", "B"};
            for (int c = 0; c < 3; ++c)
                fb.insert(names[c], Imf::Slice(Imf::FLOAT, base + c * sizeof(float), xs, ys));
            file.setFrameBuffer(fb);
            file.writePixels(image.height());
        } catch (const std::exception& e) {
            throw RuntimeError("cannot write " + path.string() + ": " + e.what());
        }
    });
}

}  // namespace glint
