#include "appliance/render/ao_file.hpp"

#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <sstream>

#include "appliance/core/atomic_file.hpp"
#include "appliance/core/errors.hpp"
#include "appliance/core/strict_number.hpp"

namespace glint::render {
namespace {

constexpr const char* kMagic = "glint-ao 1";

std::string hex64(std::uint64_t x) {
    char buf[17];
    std::snprintf(buf, sizeof buf, "%016" PRIx64, x);
    return buf;
}

std::uint64_t parse_hex64(const std::string& text, const std::string& where) {
    if (text.size() != 16 || text.find_first_not_of("0123456789abcdef") != std::string::npos)
        throw InputError(where + ": '" + text + "' is not 16 lower-case hex digits");
    return std::strtoull(text.c_str(), nullptr, 16);
}

}  // namespace

std::uint64_t fnv1a64(const void* data, std::size_t size, std::uint64_t hash) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < size; ++i) hash = (hash ^ p[i]) * 0x100000001b3ull;
    return hash;
}

std::uint64_t file_checksum(const std::filesystem::path& path, std::uint64_t* size) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw InputError(path.string() + ": cannot open the file");
    std::uint64_t hash = 0xcbf29ce484222325ull, bytes = 0;
    char buf[1 << 16];
    while (in) {
        in.read(buf, sizeof buf);
        const auto got = std::size_t(in.gcount());
        hash = fnv1a64(buf, got, hash);
        bytes += got;
    }
    if (in.bad()) throw InputError(path.string() + ": read error");
    if (size) *size = bytes;
    return hash;
}

std::filesystem::path ao_path_for(const std::filesystem::path& model) {
    std::filesystem::path p = model;
    p += ".ao";
    return p;
}

void save_ao_file(const std::filesystem::path& path, const AoFile& file) {
    std::ostringstream out;
    out << kMagic << "\n"
        << "model " << file.model_name << "\n"
        << "model-bytes " << file.model_bytes << "\n"
        << "model-fnv1a64 " << hex64(file.model_checksum) << "\n"
        << "vertices " << file.ao.size() << "\n"
        << "rays " << file.rays << "\n"
        << "max-distance " << file.max_distance_relative << "\n"
        << "data-fnv1a64 " << hex64(fnv1a64(file.ao.data(), file.ao.size() * sizeof(float))) << "\n"
        << "end\n";
    std::string bytes = out.str();
    // x86 and ARM are little-endian; the format says little-endian so that it stays defined.
    static_assert(sizeof(float) == 4);
    bytes.append(reinterpret_cast<const char*>(file.ao.data()), file.ao.size() * sizeof(float));
    write_text_atomically(path, bytes);
}

AoFile load_ao_file(const std::filesystem::path& path) {
    std::ifstream in(path, std::ios::binary);
    const std::string name = path.string();
    if (!in) throw InputError(name + ": cannot open the ao file");
    std::string line;
    if (!std::getline(in, line) || line != kMagic)
        throw InputError(name + ": not a glint ao file (the first line is not '" + std::string(kMagic) + "')");
    AoFile f;
    std::uint64_t vertices = 0, data_checksum = 0;
    bool seen[7] = {};
    const char* keys[7] = {"model", "model-bytes", "model-fnv1a64", "vertices", "rays", "max-distance", "data-fnv1a64"};
    int line_no = 1;
    while (true) {
        if (!std::getline(in, line)) throw InputError(name + ": the header has no 'end' line");
        ++line_no;
        if (line == "end") break;
        const std::string where = name + ":" + std::to_string(line_no);
        const std::size_t space = line.find(' ');
        const std::string key = line.substr(0, space), value = space == std::string::npos ? "" : line.substr(space + 1);
        int k = 0;
        while (k < 7 && key != keys[k]) ++k;
        if (k == 7) throw InputError(where + ": unknown header key '" + key + "'");
        if (seen[k]) throw InputError(where + ": '" + key + "' given twice");
        seen[k] = true;
        switch (k) {
            case 0: f.model_name = value; break;
            case 1: f.model_bytes = std::uint64_t(parse_int(value, where)); break;
            case 2: f.model_checksum = parse_hex64(value, where); break;
            case 3: vertices = std::uint64_t(parse_int(value, where)); break;
            case 4: f.rays = int(parse_int(value, where)); break;
            case 5: f.max_distance_relative = parse_double(value, where); break;
            default: data_checksum = parse_hex64(value, where); break;
        }
    }
    for (int k = 0; k < 7; ++k)
        if (!seen[k]) throw InputError(name + ": the header has no '" + keys[k] + "' line");
    if (vertices > (std::uint64_t(1) << 32)) throw InputError(name + ": " + std::to_string(vertices) + " vertices is too many");
    // The count decides an allocation: hold it to the bytes that follow the header first, so that
    // a corrupt count cannot make the kiosk zero-fill gigabytes (tests/fuzz's ao target: 16 GiB
    // from a 150-byte file).
    const std::streamoff data_start = in.tellg();
    in.seekg(0, std::ios::end);
    const std::streamoff file_end = in.tellg();
    in.seekg(data_start);
    if (data_start < 0 || file_end < data_start) throw InputError(name + ": cannot find the data block");
    const std::uint64_t following = std::uint64_t(file_end - data_start);
    if (vertices * sizeof(float) > following)
        throw InputError(name + ": the data block is short: the header says " + std::to_string(vertices) + " vertices (" +
                         std::to_string(vertices * sizeof(float)) + " bytes), " + std::to_string(following) +
                         " bytes follow it");
    f.ao.resize(std::size_t(vertices));
    in.read(reinterpret_cast<char*>(f.ao.data()), std::streamsize(f.ao.size() * sizeof(float)));
    if (std::uint64_t(in.gcount()) != vertices * sizeof(float))
        throw InputError(name + ": the data block is short (" + std::to_string(in.gcount()) + " of " +
                         std::to_string(vertices * sizeof(float)) + " bytes)");
    if (in.peek() != std::char_traits<char>::eof()) throw InputError(name + ": bytes after the data block");
    if (fnv1a64(f.ao.data(), f.ao.size() * sizeof(float)) != data_checksum)
        throw InputError(name + ": the data block does not match its checksum (a corrupt file)");
    for (float a : f.ao)
        if (!(a >= 0.0f && a <= 1.0f)) throw InputError(name + ": an ao value outside [0, 1]");
    return f;
}

AoLookup find_ao_for(const std::filesystem::path& model, std::size_t vertex_count, const std::filesystem::path& ao_file) {
    AoLookup r;
    const std::filesystem::path path = ao_file.empty() ? ao_path_for(model) : ao_file;
    if (!std::filesystem::exists(path)) {
        r.status = "none (no " + path.string() + ")";
        return r;
    }
    r.found = true;
    AoFile f;
    try {
        f = load_ao_file(path);
    } catch (const InputError& e) {
        r.status = std::string("unreadable: ") + e.what();
        return r;
    }
    std::uint64_t bytes = 0;
    const std::uint64_t checksum = file_checksum(model, &bytes);
    if (bytes != f.model_bytes || checksum != f.model_checksum) {
        r.status = "stale: " + path.string() + " was baked from another version of " + model.string() +
                   " (size or checksum differ; run glint bake-ao " + model.string() + ")";
        return r;
    }
    if (f.ao.size() != vertex_count) {
        r.status = "stale: " + path.string() + " has " + std::to_string(f.ao.size()) + " vertices, the model " +
                   std::to_string(vertex_count) + " (run glint bake-ao " + model.string() + ")";
        return r;
    }
    r.ao = std::move(f.ao);
    r.used = true;
    r.status = "loaded " + path.string() + " (" + std::to_string(f.rays) + " rays, max distance " +
               std::to_string(f.max_distance_relative) + " radius)";
    return r;
}

}  // namespace glint::render
