// Tests of core/atomic_file: replacement, no leftover temp files, failure keeps the old file.
#include <gtest/gtest.h>

#include "tests/unit/test_support.hpp"
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "appliance/core/atomic_file.hpp"
#include "appliance/core/errors.hpp"

namespace glint {
namespace {

namespace fs = std::filesystem;

class AtomicFile : public glint::testing::TempDirTest {};

std::string read_all(const fs::path& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

TEST_F(AtomicFile, WriteTextCreatesAndReplaces) {
    const fs::path target = dir_ / "state.json";
    write_text_atomically(target, "first version, rather long\n");
    EXPECT_EQ(read_all(target), "first version, rather long\n");
    write_text_atomically(target, "second");  // shorter: no tail of the old content may survive
    EXPECT_EQ(read_all(target), "second");
    write_text_atomically(target, "");
    EXPECT_TRUE(fs::exists(target));
    EXPECT_EQ(fs::file_size(target), 0u);
    EXPECT_EQ(listing(), std::vector<std::string>{"state.json"});
}

TEST_F(AtomicFile, WriteTextHandlesBinaryBytes) {
    const fs::path target = dir_ / "blob";
    const std::string bytes("a\0b\xff\n", 5);
    write_text_atomically(target, bytes);
    EXPECT_EQ(read_all(target), bytes);
}

TEST_F(AtomicFile, TempFileIsInTheTargetDirectory) {
    // rename() is only atomic within one file system, so the temp must sit beside the target.
    const fs::path target = dir_ / "out.bin";
    fs::path seen;
    write_file_atomically(target, [&](const fs::path& tmp) {
        seen = tmp;
        std::ofstream(tmp) << "x";
    });
    EXPECT_EQ(seen.parent_path(), dir_);
    EXPECT_NE(seen, target);
    EXPECT_FALSE(fs::exists(seen));
    EXPECT_EQ(read_all(target), "x");
    EXPECT_EQ(listing(), std::vector<std::string>{"out.bin"});
}

TEST_F(AtomicFile, ThrowingWriterKeepsTheOldContentAndLeavesNoTemp) {
    const fs::path target = dir_ / "config.txt";
    write_text_atomically(target, "old content");
    EXPECT_THROW(write_file_atomically(target,
                                       [](const fs::path& tmp) {
                                           std::ofstream(tmp) << "half-written new cont";
                                           throw std::runtime_error("disk on fire");
                                       }),
                 std::runtime_error);
    EXPECT_EQ(read_all(target), "old content");
    EXPECT_EQ(listing(), std::vector<std::string>{"config.txt"});
}

TEST_F(AtomicFile, ThrowingWriterBeforeCreatingTheTempLeavesNothing) {
    const fs::path target = dir_ / "new.txt";
    EXPECT_THROW(write_file_atomically(target, [](const fs::path&) { throw InputError("no"); }),
                 InputError);
    EXPECT_FALSE(fs::exists(target));
    EXPECT_TRUE(listing().empty());
}

TEST_F(AtomicFile, WriterThatCreatesNothingIsAnError) {
    // Nothing to fsync or rename: the commit must fail rather than report success.
    const fs::path target = dir_ / "ghost.txt";
    EXPECT_ANY_THROW(write_file_atomically(target, [](const fs::path&) {}));
    EXPECT_FALSE(fs::exists(target));
    EXPECT_TRUE(listing().empty());
}

TEST_F(AtomicFile, WriteIntoAMissingDirectoryThrowsAndLeavesNothing) {
    EXPECT_ANY_THROW(write_text_atomically(dir_ / "missing" / "x.txt", "data"));
    EXPECT_FALSE(fs::exists(dir_ / "missing"));
    EXPECT_TRUE(listing().empty());
}

void expect_input_error_naming(const fs::path& dir) {
    try {
        ensure_writable_directory(dir);
        ADD_FAILURE() << "ensure_writable_directory(" << dir << ") did not throw";
    } catch (const InputError& e) {
        EXPECT_NE(std::string(e.what()).find(dir.string()), std::string::npos) << e.what();
    } catch (const std::exception& e) {
        ADD_FAILURE() << "threw something other than InputError: " << e.what();
    }
}

TEST_F(AtomicFile, EnsureWritableDirectoryRejectsAPathUnderARegularFile) {
    const fs::path file = dir_ / "plain_file";
    write_text_atomically(file, "not a directory");
    expect_input_error_naming(file / "sub");
    expect_input_error_naming(file / "sub" / "deeper");
    EXPECT_EQ(read_all(file), "not a directory");
}

TEST_F(AtomicFile, EnsureWritableDirectoryRejectsARegularFile) {
    const fs::path file = dir_ / "plain_file";
    write_text_atomically(file, "x");
    expect_input_error_naming(file);
}

TEST_F(AtomicFile, EnsureWritableDirectoryCreatesMissingDirectories) {
    const fs::path nested = dir_ / "a" / "b" / "c";
    ASSERT_FALSE(fs::exists(dir_ / "a"));
    EXPECT_NO_THROW(ensure_writable_directory(nested));
    EXPECT_TRUE(fs::is_directory(nested));
    EXPECT_NO_THROW(ensure_writable_directory(nested));  // existing: fine
    write_text_atomically(nested / "f", "ok");
    EXPECT_EQ(read_all(nested / "f"), "ok");
}

}  // namespace
}  // namespace glint
