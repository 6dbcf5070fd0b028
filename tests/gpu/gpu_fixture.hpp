// One surfaceless EGL display and GLES context for all GPU tests of the binary.
#pragma once

#include <gtest/gtest.h>

#include <memory>

#include "appliance/gl/gl_context.hpp"

namespace glint::test {

class GpuTest : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        if (!display_) {
            display_ = std::make_unique<gl::EglDisplay>(gl::EglDisplay::surfaceless());
            context_ = std::make_unique<gl::GlContext>(*display_);
        }
        context_->make_current();
    }
    static const gl::GlContext& context() { return *context_; }

private:
    static inline std::unique_ptr<gl::EglDisplay> display_;
    static inline std::unique_ptr<gl::GlContext> context_;
};

}  // namespace glint::test
