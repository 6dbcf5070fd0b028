// The appliance's state directory (docs/state.md): items (the last scene, the camera calibration,
// the PIN lock, ...) saved so that a crash or a power cut leaves the complete old or the complete
// new version, never a mix, and loaded only when every file matches its checksum.
//
// An item is one or more files saved together. Each save writes a new generation directory
// <dir>/.<item>.gen/<generation>/ holding the files and MANIFEST.json (each file's size and 64-bit
// FNV-1a hash), syncs it, then points <dir>/<item> at it by renaming a new symlink over the old
// one (the one atomic step), syncs <dir>, and removes the older generations. <dir>/<item> is read
// as before: a directory item (several files: <dir>/scene/env.exr) links to the generation
// directory, a file item (one file named as the item: <dir>/pin-lock.json) to the file in it.
//
// Loading verifies the manifest and every file (and, through a caller's check, that they parse).
// A faulty item is moved aside, never deleted, into <dir>/corrupt/<UTC time>/ with REASON.txt,
// logged with the file and the reason, and the caller uses its defaults. One writer per item
// (the kiosk's process) is assumed.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "appliance/core/errors.hpp"

namespace glint::state {

using Log = std::function<void(const std::string&)>;

// One file of an item: `write` makes the whole file at the path it is given (the store syncs it
// and computes its checksum). The name has no '/'.
struct StateFile {
    std::string name;
    std::function<void(const std::filesystem::path& path)> write;
};
StateFile text_file(std::string name, std::string text);
// A file written already (e.g. by the capture), moved into the item (same file system) or copied.
StateFile moved_file(std::string name, std::filesystem::path from);

// A save that failed: the message names the item and the file or directory at fault and the
// system's reason ("No space left on device", "Read-only file system"); the previous version of
// the item is untouched and still loads.
class SaveError : public RuntimeError {
public:
    using RuntimeError::RuntimeError;
};

// Saves a new version of `item` in `dir` (created if missing). A file item when `files` is one
// file named `item`, a directory item otherwise. Throws SaveError; records it for
// last_save_error().
void save_item(const std::filesystem::path& dir, const std::string& item, const std::vector<StateFile>& files);

// The most recent failed save (its message) of any item that has not been saved successfully
// since: what the maintenance menu shows. Thread-safe.
std::optional<std::string> last_save_error();

// What to do with an item at <dir>/<item> that the store did not write (no generation, no
// manifest): a file copied in by a technician, an older build's file.
enum class Unverified {
    Accept,    // load it if the caller's check passes (logged as unverified)
    SetAside,  // a fault: moved aside like a corrupt item
};

struct LoadPolicy {
    std::vector<std::string> files;  // files that must be in the item
    Unverified unverified = Unverified::SetAside;
    // Throws (any std::exception, its what() the reason) when the item's files do not parse.
    // Gets <dir>/<item>.
    std::function<void(const std::filesystem::path& item_path)> check;
};

struct LoadedItem {
    std::optional<std::filesystem::path> path;  // <dir>/<item>, verified; nullopt: use the defaults
    bool verified = false;                      // false with a path: accepted unverified
    bool fault = false;                         // the item was there but faulty (set aside if it could be)
    std::string defaults_because;               // why there is no path ("none saved yet" or the fault)
    std::filesystem::path set_aside;            // where a faulty item went ("" = nothing moved)
};

// Verifies <dir>/<item>. Logs every fault and every unverified item accepted. Never throws for a
// missing or faulty item (the defaults are the caller's); removes generations left by a save cut
// short.
LoadedItem load_item(const std::filesystem::path& dir, const std::string& item, const LoadPolicy& policy,
                     const Log& log);

// Moves <dir>/<item> (the link and its generation, or an unverified file or directory) into
// <dir>/corrupt/<UTC YYYYMMDD-HHMMSS>[-N]/ with REASON.txt; returns that directory. Throws
// RuntimeError when nothing could be moved.
// The newest kCorruptKept sets are kept (a file that is corrupted at every start must not fill
// the state partition); older ones are removed.
std::filesystem::path set_aside(const std::filesystem::path& dir, const std::string& item, const std::string& reason);
inline constexpr std::size_t kCorruptKept = 16;
// How many sets <dir>/corrupt/ holds (what the maintenance menu's status page shows).
std::size_t corrupt_sets(const std::filesystem::path& dir);

// Whether <path> is an item the store wrote (a symlink into its generations).
bool is_store_item(const std::filesystem::path& path);

// 64-bit FNV-1a of a file's bytes (what the manifest holds), and of a string.
std::uint64_t file_hash(const std::filesystem::path& path);
std::uint64_t fnv1a64(const void* data, std::size_t size, std::uint64_t h = 0xcbf29ce484222325ull);

inline constexpr const char* kManifestName = "MANIFEST.json";
inline constexpr const char* kCorruptDir = "corrupt";

}  // namespace glint::state
