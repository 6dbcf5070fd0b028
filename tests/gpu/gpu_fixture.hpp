// One surfaceless EGL display and GLES context for all GPU tests of the binary.
#pragma once

#include <gtest/gtest.h>

#include <memory>

#include "appliance/render/gl_context.hpp"

namespace glint::test {

class GpuTest : public ::testing::Test {
protected:
    static void SetUpTestSuite() {
        if (!display_) {
            display_ = std::make_unique<render::EglDisplay>(render::EglDisplay::surfaceless());
            context_ = std::make_unique<render::GlContext>(*display_);
        }
        context_->make_current();
    }
    static const render::GlContext& context() { return *context_; }

private:
    static inline std::unique_ptr<render::EglDisplay> display_;
    static inline std::unique_ptr<render::GlContext> context_;
};

}  // namespace glint::test
