// The file a bake is stored in, beside its model: MODEL.ao (docs/render.md, "The .ao file").
//
//   glint-ao 1                          format and version
//   model bunny.obj                     the model's file name (informational)
//   model-bytes 123456                  the model file's size
//   model-fnv1a64 0123456789abcdef      FNV-1a 64 of the model file's bytes
//   vertices 9248                       the loaded mesh's vertex count
//   rays 256                            how it was baked
//   max-distance 0.5                    (times the model's bounding radius)
//   data-fnv1a64 fedcba9876543210       FNV-1a 64 of the data block's bytes
//   end
//   <vertices x float32, little-endian: ao of vertex 0, 1, ...>
//
// The header is text so that `head -9 MODEL.ao` tells what it is; the data is binary so that a
// 100k-vertex model takes 400 kB. A stale file (the model changed since the bake) is detected by
// the model's size and checksum, and by the vertex count.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace glint::render {

struct AoFile {
    std::string model_name;
    std::uint64_t model_bytes = 0;
    std::uint64_t model_checksum = 0;
    int rays = 0;
    double max_distance_relative = 0;
    std::vector<float> ao;  // one per vertex
};

// FNV-1a 64 of a byte string and of a file's bytes (throws InputError naming an unreadable file).
std::uint64_t fnv1a64(const void* data, std::size_t size, std::uint64_t hash = 0xcbf29ce484222325ull);
std::uint64_t file_checksum(const std::filesystem::path& path, std::uint64_t* size = nullptr);

// MODEL.ao: the model's path with ".ao" appended (bunny.obj -> bunny.obj.ao).
std::filesystem::path ao_path_for(const std::filesystem::path& model);

// Writes atomically. Reads, throwing InputError "FILE: what" for a file that is not one (bad magic
// or version, a malformed header line, a short or corrupt data block).
void save_ao_file(const std::filesystem::path& path, const AoFile& file);
AoFile load_ao_file(const std::filesystem::path& path);

// The ao of `model` for a mesh of `vertex_count` vertices loaded from it, from `ao_file` (default
// MODEL.ao) when that exists and matches. `status` says what happened, for the log: "none" (no
// file), "loaded FILE", or why the file was not used ("stale: ...", "unreadable: ...").
struct AoLookup {
    std::vector<float> ao;  // empty when not used
    bool found = false;     // a file was there
    bool used = false;
    std::string status;
};
AoLookup find_ao_for(const std::filesystem::path& model, std::size_t vertex_count,
                     const std::filesystem::path& ao_file = {});

}  // namespace glint::render
