// Power-loss-safe file writes: write a temp file in the same directory, fsync it,
// rename it over the target, fsync the directory. A reader sees the old file or
// the new one, never half of one (docs/architecture.md, "Files and state").
#pragma once

#include <filesystem>
#include <functional>
#include <string_view>

namespace glint {

// Calls write(temp_path) to produce the file, then commits it atomically to
// `target`. If write throws, the temp file is removed and the target is untouched.
void write_file_atomically(const std::filesystem::path& target,
                           const std::function<void(const std::filesystem::path&)>& write);

// Convenience: atomically write a byte string.
void write_text_atomically(const std::filesystem::path& target, std::string_view text);

// Makes the renames and creations inside `dir` durable (fsync of the directory), e.g. after
// moving staged files into it.
void sync_directory(const std::filesystem::path& dir);

// Throws InputError naming `dir` unless it exists (or can be created) and is writable.
void ensure_writable_directory(const std::filesystem::path& dir);

}  // namespace glint
