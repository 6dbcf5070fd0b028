// The state directory's items: generations behind an atomically swapped symlink, each with a
// checksummed manifest (state_store.hpp, docs/state.md).
#include "appliance/core/state_store.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <cerrno>
#include <cinttypes>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <fstream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>

#include "appliance/core/atomic_file.hpp"
#include "appliance/core/unique_fd.hpp"

namespace glint::state {
namespace fs = std::filesystem;
using nlohmann::json;

namespace {

constexpr const char* kManifestFormat = "glint-state-manifest";
constexpr int kManifestVersion = 1;

using Fd = UniqueFd;

std::string errno_text() { return std::strerror(errno); }

// Every save's failure goes through here: the message names the item and what failed.
[[noreturn]] void fail(const fs::path& item_path, const std::string& what) {
    throw SaveError("cannot save " + item_path.string() + ": " + what);
}

// `sync`: fsync before returning (the store's own files; an item's files are synced by the save).
void write_all(const fs::path& path, const std::string& bytes, bool sync = true) {
    Fd fd(::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644));
    if (fd.get() < 0) throw RuntimeError(path.string() + ": cannot create: " + errno_text());
    std::size_t done = 0;
    while (done < bytes.size()) {
        const ssize_t n = ::write(fd.get(), bytes.data() + done, bytes.size() - done);
        if (n < 0) {
            if (errno == EINTR) continue;
            throw RuntimeError(path.string() + ": cannot write: " + errno_text());
        }
        done += std::size_t(n);
    }
    if (sync && ::fsync(fd.get()) != 0) throw RuntimeError(path.string() + ": cannot sync: " + errno_text());
}

void fsync_file(const fs::path& path) {
    Fd fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
    if (fd.get() < 0 || ::fsync(fd.get()) != 0) throw RuntimeError(path.string() + ": cannot sync: " + errno_text());
}

std::string hex64(std::uint64_t v) {
    char text[17];
    std::snprintf(text, sizeof text, "%016" PRIx64, v);
    return text;
}

std::string gen_root_name(const std::string& item) { return "." + item + ".gen"; }

std::string gen_name(std::uint64_t generation) {
    char text[24];
    std::snprintf(text, sizeof text, "%010" PRIu64, generation);
    return text;
}

std::optional<std::uint64_t> parse_gen(const std::string& s) {
    if (s.empty() || s.size() > 19 || !std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; }))
        return std::nullopt;
    return std::stoull(s);
}

// A file item is one file named as the item: its link points at the file in the generation.
bool is_file_item(const std::string& item, const std::vector<StateFile>& files) {
    return files.size() == 1 && files.front().name == item;
}

struct LinkTarget {
    std::uint64_t generation = 0;
    bool file_item = false;
};

// "<.item.gen>/<generation>" (a directory item) or ".../<generation>/<item>" (a file item);
// anything else is not the store's link.
std::optional<LinkTarget> parse_link(const std::string& item, const fs::path& target) {
    std::vector<std::string> parts;
    for (const fs::path& p : target) parts.push_back(p.string());
    if (parts.size() < 2 || parts.size() > 3 || parts[0] != gen_root_name(item)) return std::nullopt;
    const std::optional<std::uint64_t> g = parse_gen(parts[1]);
    if (!g) return std::nullopt;
    if (parts.size() == 3 && parts[2] != item) return std::nullopt;
    return LinkTarget{*g, parts.size() == 3};
}

std::optional<fs::path> read_link(const fs::path& path) {
    std::error_code ec;
    if (!fs::is_symlink(fs::symlink_status(path, ec))) return std::nullopt;
    fs::path target = fs::read_symlink(path, ec);
    if (ec) return std::nullopt;
    return target;
}

// Removes what a save cut short left behind: generations other than `keep` and link temps.
// Garbage only: a failure here (a read-only directory) changes nothing that is read.
void remove_leftovers(const fs::path& dir, const std::string& item, const std::string& keep) {
    try {
        std::error_code ec;
        const fs::path root = dir / gen_root_name(item);
        if (fs::is_directory(root, ec))
            for (const fs::directory_entry& e : fs::directory_iterator(root, ec))
                if (e.path().filename() != keep) fs::remove_all(e.path(), ec);
        const std::string link_temp = "." + item + ".link-";
        for (const fs::directory_entry& e : fs::directory_iterator(dir, ec))
            if (e.path().filename().string().rfind(link_temp, 0) == 0) fs::remove(e.path(), ec);
    } catch (const std::exception&) {
    }
}

std::mutex& errors_mutex() {
    static std::mutex m;
    return m;
}
// Item path -> (order, message) of its last failed save, until it saves again.
std::map<std::string, std::pair<std::uint64_t, std::string>>& save_errors() {
    static std::map<std::string, std::pair<std::uint64_t, std::string>> errors;
    return errors;
}
std::uint64_t& error_order() {
    static std::uint64_t order = 0;
    return order;
}

void record_save(const fs::path& item_path, const std::string* error) {
    const std::lock_guard lock(errors_mutex());
    if (error) save_errors()[item_path.string()] = {++error_order(), *error};
    else save_errors().erase(item_path.string());
}

std::string utc_stamp() {
    const std::time_t now = std::time(nullptr);
    std::tm utc{};
    gmtime_r(&now, &utc);
    char text[32];
    std::strftime(text, sizeof text, "%Y%m%d-%H%M%S", &utc);
    return text;
}

void save_item_unrecorded(const fs::path& dir, const std::string& item, const std::vector<StateFile>& files) {
    const fs::path item_path = dir / item;
    if (item.empty() || item.find('/') != std::string::npos || item[0] == '.' || item == kCorruptDir)
        fail(item_path, "'" + item + "' cannot name a state item");
    if (files.empty()) fail(item_path, "no files to save");
    for (const StateFile& f : files)
        if (f.name.empty() || f.name.find('/') != std::string::npos || f.name == kManifestName)
            fail(item_path, "'" + f.name + "' cannot name a file of a state item");
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) fail(item_path, dir.string() + ": cannot create the state directory: " + ec.message());
    const bool file_item = is_file_item(item, files);

    // What is there now: the store's link (its generation comes next), nothing, or something the
    // store did not write.
    std::uint64_t generation = 1;
    const fs::file_status status = fs::symlink_status(item_path, ec);
    if (const std::optional<fs::path> target = read_link(item_path)) {
        if (const std::optional<LinkTarget> link = parse_link(item, *target)) generation = link->generation + 1;
    } else if (fs::is_directory(status)) {
        // An empty directory (made by a caller before the first save) gives way; anything else
        // in it is not the store's to replace.
        if (file_item || !fs::remove(item_path, ec))
            fail(item_path, "a directory the state store did not write is in the way (" +
                                (ec ? ec.message() : std::string("not empty")) + "); move it away");
    }
    const std::string gen = gen_name(generation);
    const fs::path root = dir / gen_root_name(item);
    const fs::path gen_dir = root / gen;
    // A save of this generation cut short before it was linked: start it again.
    fs::remove_all(gen_dir, ec);
    fs::create_directories(gen_dir, ec);
    if (ec) fail(item_path, gen_dir.string() + ": cannot create: " + ec.message());
    bool linked = false;  // from the rename on, the new generation is what readers see: it stays
    try {
        json manifest{{"format", kManifestFormat}, {"version", kManifestVersion}, {"item", item},
                      {"generation", generation}, {"files", json::array()}};
        for (const StateFile& f : files) {
            const fs::path path = gen_dir / f.name;
            f.write(path);
            fsync_file(path);
            manifest["files"].push_back({{"name", f.name}, {"size", fs::file_size(path)}, {"fnv1a64", hex64(file_hash(path))}});
        }
        write_all(gen_dir / kManifestName, manifest.dump(1) + "\n");
        sync_directory(gen_dir);
        sync_directory(root);
        // The one step that changes what a reader sees.
        const fs::path target = fs::path(gen_root_name(item)) / gen / (file_item ? fs::path(item) : fs::path());
        const fs::path link_temp = dir / ("." + item + ".link-" + std::to_string(::getpid()));
        fs::remove(link_temp, ec);
        std::string target_text = target.string();
        if (!target_text.empty() && target_text.back() == '/') target_text.pop_back();
        if (::symlink(target_text.c_str(), link_temp.c_str()) != 0)
            throw RuntimeError(link_temp.string() + ": cannot create the link: " + errno_text());
        if (::rename(link_temp.c_str(), item_path.c_str()) != 0) {
            const std::string why = errno_text();
            fs::remove(link_temp, ec);
            throw RuntimeError(item_path.string() + ": cannot replace: " + why);
        }
        linked = true;
        sync_directory(dir);
    } catch (const std::exception& e) {
        if (!linked) fs::remove_all(gen_dir, ec);
        // Linked but not synced: the new version is in place, a power cut may still undo it.
        fail(item_path, e.what());
    }
    // The new version is durable; the old ones are garbage now.
    remove_leftovers(dir, item, gen);
}

}  // namespace

std::uint64_t fnv1a64(const void* data, std::size_t size, std::uint64_t h) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (std::size_t k = 0; k < size; ++k) {
        h ^= p[k];
        h *= 0x100000001b3ull;
    }
    return h;
}

std::uint64_t file_hash(const fs::path& path) {
    Fd fd(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
    if (fd.get() < 0) throw RuntimeError(path.string() + ": cannot open: " + errno_text());
    std::uint64_t h = 0xcbf29ce484222325ull;
    std::vector<char> buffer(1 << 16);
    for (;;) {
        const ssize_t n = ::read(fd.get(), buffer.data(), buffer.size());
        if (n < 0) {
            if (errno == EINTR) continue;
            throw RuntimeError(path.string() + ": cannot read: " + errno_text());
        }
        if (n == 0) return h;
        h = fnv1a64(buffer.data(), std::size_t(n), h);
    }
}

StateFile text_file(std::string name, std::string text) {
    return {std::move(name), [text = std::move(text)](const fs::path& path) { write_all(path, text, false); }};
}

StateFile moved_file(std::string name, fs::path from) {
    return {std::move(name), [from = std::move(from)](const fs::path& path) {
                if (::rename(from.c_str(), path.c_str()) == 0) return;
                if (errno != EXDEV) throw RuntimeError(from.string() + ": cannot move into " + path.string() + ": " + errno_text());
                std::error_code ec;
                fs::copy_file(from, path, fs::copy_options::overwrite_existing, ec);
                if (ec) throw RuntimeError(from.string() + ": cannot copy to " + path.string() + ": " + ec.message());
            }};
}

void save_item(const fs::path& dir, const std::string& item, const std::vector<StateFile>& files) {
    try {
        save_item_unrecorded(dir, item, files);
    } catch (const SaveError& e) {
        const std::string message = e.what();
        record_save(dir / item, &message);
        throw;
    }
    record_save(dir / item, nullptr);
}

std::optional<std::string> last_save_error() {
    const std::lock_guard lock(errors_mutex());
    const std::pair<std::uint64_t, std::string>* newest = nullptr;
    for (const auto& [item, error] : save_errors())
        if (!newest || error.first > newest->first) newest = &error;
    if (!newest) return std::nullopt;
    return newest->second;
}

bool is_store_item(const fs::path& path) {
    const std::optional<fs::path> target = read_link(path);
    return target && parse_link(path.filename().string(), *target).has_value();
}

std::size_t corrupt_sets(const fs::path& dir) {
    std::error_code ec;
    std::size_t n = 0;
    for (const fs::directory_entry& e : fs::directory_iterator(dir / kCorruptDir, ec))
        if (e.is_directory(ec)) ++n;
    return n;
}

fs::path set_aside(const fs::path& dir, const std::string& item, const std::string& reason) {
    const fs::path item_path = dir / item;
    std::error_code ec;
    const fs::path corrupt = dir / kCorruptDir;
    fs::create_directories(corrupt, ec);
    if (ec) throw RuntimeError(corrupt.string() + ": cannot create: " + ec.message());
    // Several faults in one second each get their own directory, numbered after the highest
    // number of that second still there (a pruned name is not used again: it would sort first).
    const std::string stamp = utc_stamp();
    long first = 1;
    for (const fs::directory_entry& e : fs::directory_iterator(corrupt, ec)) {
        const std::string name = e.path().filename().string();
        if (name == stamp) first = std::max(first, 2L);
        else if (name.rfind(stamp + "-", 0) == 0) first = std::max(first, std::strtol(name.c_str() + stamp.size() + 1, nullptr, 10) + 1);
    }
    fs::path dest;
    for (long k = first;; ++k) {
        dest = corrupt / (k == 1 ? stamp : stamp + "-" + std::to_string(k));
        if (fs::create_directory(dest, ec)) break;
        if (ec) throw RuntimeError(dest.string() + ": cannot create: " + ec.message());
    }
    write_all(dest / "REASON.txt", item_path.string() + ": " + reason + "\n");
    // The oldest sets go. Their names are UTC stamps, which sort by time, and the Nth set of
    // one second "STAMP-N" (N numerically: "-10" after "-9").
    std::vector<std::pair<std::pair<std::string, long>, fs::path>> sets;
    for (const fs::directory_entry& e : fs::directory_iterator(corrupt, ec)) {
        if (!e.is_directory(ec)) continue;
        const std::string name = e.path().filename().string();
        const std::size_t dash = name.find('-', 9);  // after YYYYMMDD-
        const long n = dash == std::string::npos ? 1 : std::strtol(name.c_str() + dash + 1, nullptr, 10);
        sets.push_back({{name.substr(0, dash), n}, e.path()});
    }
    std::sort(sets.begin(), sets.end());
    for (std::size_t k = 0; k + kCorruptKept < sets.size(); ++k)
        if (sets[k].second != dest) fs::remove_all(sets[k].second, ec);
    if (const std::optional<fs::path> target = read_link(item_path)) {
        if (const std::optional<LinkTarget> link = parse_link(item, *target)) {
            const fs::path gen_dir = dir / gen_root_name(item) / gen_name(link->generation);
            if (fs::exists(gen_dir, ec) && ::rename(gen_dir.c_str(), (dest / (item + ".generation-" + gen_name(link->generation))).c_str()) != 0)
                throw RuntimeError(gen_dir.string() + ": cannot move into " + dest.string() + ": " + errno_text());
        }
        // The link itself goes too (it points nowhere now), so that the item reads as absent.
    }
    if (::rename(item_path.c_str(), (dest / item).c_str()) != 0 && errno != ENOENT)
        throw RuntimeError(item_path.string() + ": cannot move into " + dest.string() + ": " + errno_text());
    sync_directory(dest);
    sync_directory(dir);
    return dest;
}

LoadedItem load_item(const fs::path& dir, const std::string& item, const LoadPolicy& policy, const Log& log) {
    const fs::path item_path = dir / item;
    LoadedItem r;
    const auto fault = [&](const std::string& reason) {
        r.path.reset();
        r.verified = false;
        r.fault = true;
        r.defaults_because = reason;
        try {
            r.set_aside = set_aside(dir, item, reason);
            if (log) log("state: " + item_path.string() + ": " + reason + "; set aside in " + r.set_aside.string() + ", using the defaults");
        } catch (const std::exception& e) {
            if (log) log("state: " + item_path.string() + ": " + reason + "; could not be set aside (" + e.what() + "), using the defaults");
        }
        return r;
    };
    const auto checked = [&]() -> std::optional<std::string> {
        if (!policy.check) return std::nullopt;
        try {
            policy.check(item_path);
        } catch (const std::exception& e) {
            return std::string("does not parse: ") + e.what();
        }
        return std::nullopt;
    };

    std::error_code ec;
    const fs::file_status status = fs::symlink_status(item_path, ec);
    if (!fs::exists(status) && !fs::is_symlink(status)) {
        r.defaults_because = "none saved yet";
        return r;
    }
    // A link the store did not make (a technician's link to a file elsewhere) is read as what it
    // points at: an item the store did not write.
    std::optional<fs::path> target = read_link(item_path);
    if (target && !parse_link(item, *target)) target.reset();
    if (!target) {
        // Not the store's: an empty directory made before the first save is "none yet".
        if (fs::is_directory(status) && fs::is_empty(item_path, ec)) {
            r.defaults_because = "none saved yet";
            return r;
        }
        if (policy.unverified == Unverified::SetAside) return fault("not written by the state store (no manifest, no checksum)");
        if (const std::optional<std::string> problem = checked()) return fault(*problem);
        if (log) log("state: " + item_path.string() + ": not written by the state store (no checksum); loaded unverified");
        r.path = item_path;
        return r;
    }
    const std::optional<LinkTarget> link = parse_link(item, *target);
    const std::string gen = gen_name(link->generation);
    const fs::path gen_dir = dir / gen_root_name(item) / gen;
    if (!fs::is_directory(gen_dir, ec)) return fault("its generation " + gen_dir.string() + " is missing");
    const fs::path manifest_path = gen_dir / kManifestName;
    if (!fs::is_regular_file(manifest_path, ec)) return fault(manifest_path.string() + ": missing");
    json manifest;
    try {
        std::ifstream in(manifest_path);
        std::stringstream text;
        text << in.rdbuf();
        manifest = json::parse(text.str());
        if (manifest.at("format") != kManifestFormat || manifest.at("version") != kManifestVersion)
            throw std::runtime_error("not a version " + std::to_string(kManifestVersion) + " state manifest");
        if (manifest.at("item") != item) throw std::runtime_error("the manifest of another item");
        if (manifest.at("generation") != link->generation) throw std::runtime_error("the manifest of another generation");
        if (!manifest.at("files").is_array() || manifest.at("files").empty()) throw std::runtime_error("no files");
    } catch (const std::exception& e) {
        return fault(manifest_path.string() + ": unreadable (" + e.what() + ")");
    }
    std::vector<std::string> listed;
    for (const json& f : manifest["files"]) {
        std::string name, hash;
        std::uintmax_t size = 0;
        try {
            name = f.at("name").get<std::string>();
            size = f.at("size").get<std::uintmax_t>();
            hash = f.at("fnv1a64").get<std::string>();
        } catch (const std::exception& e) {
            return fault(manifest_path.string() + ": unreadable (" + e.what() + ")");
        }
        if (name.empty() || name.find('/') != std::string::npos || name == kManifestName)
            return fault(manifest_path.string() + ": lists a file named '" + name + "'");
        const fs::path file = gen_dir / name;
        if (!fs::is_regular_file(file, ec)) return fault(name + ": missing");
        const std::uintmax_t actual = fs::file_size(file, ec);
        if (ec || actual != size)
            return fault(name + ": " + std::to_string(actual) + " bytes, the manifest says " + std::to_string(size));
        std::uint64_t h = 0;
        try {
            h = file_hash(file);
        } catch (const std::exception& e) {
            return fault(name + ": " + e.what());
        }
        if (hex64(h) != hash) return fault(name + ": checksum " + hex64(h) + ", the manifest says " + hash);
        listed.push_back(name);
    }
    if (link->file_item && (listed.size() != 1 || listed.front() != item))
        return fault(manifest_path.string() + ": a file item must hold one file named " + item);
    for (const std::string& want : policy.files)
        if (std::find(listed.begin(), listed.end(), want) == listed.end())
            return fault(want + ": not in the manifest");
    if (const std::optional<std::string> problem = checked()) return fault(*problem);
    remove_leftovers(dir, item, gen);
    r.path = item_path;
    r.verified = true;
    return r;
}

}  // namespace glint::state
