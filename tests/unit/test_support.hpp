// Helpers shared by the unit tests: a per-test scratch directory and simple maps.
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <string>
#include <vector>

#include "appliance/core/hdr_image.hpp"

namespace glint::testing {

// A fresh directory per test under the system temp dir, removed afterwards.
class TempDirTest : public ::testing::Test {
protected:
    void SetUp() override {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        dir_ = std::filesystem::temp_directory_path() /
               ("glint_" + std::string(info->test_suite_name()) + "_" + std::to_string(::getpid()) + "_" +
                info->name());
        std::filesystem::remove_all(dir_);
        std::filesystem::create_directories(dir_);
    }
    void TearDown() override { std::filesystem::remove_all(dir_); }

    // File names in the directory, sorted.
    std::vector<std::string> listing() const {
        std::vector<std::string> names;
        for (const auto& e : std::filesystem::directory_iterator(dir_)) names.push_back(e.path().filename());
        std::sort(names.begin(), names.end());
        return names;
    }

    std::filesystem::path dir_;
};

inline HdrImage constant_map(int w, int h, Rgb c) {
    HdrImage img(w, h);
    for (int j = 0; j < h; ++j)
        for (int i = 0; i < w; ++i) img.set(i, j, c);
    return img;
}

}  // namespace glint::testing
