# glint_ui_screens (docs/screens.md): Dear ImGui drawn by our own GLES 3.0 backend on the appliance's
# EGL context, the visitor screens over the 3D frame, the maintenance menu, the strings resource
# and the system status helpers. Draws only; the kiosk (glint_ui) decides what and does the I/O.
find_package(PkgConfig REQUIRED)
# Debian's libimgui-dev 1.86: a static libimgui.a with every backend compiled in, of which we use
# none (its OpenGL3 backend loads desktop GL through its own loader); imgui_freetype is in it too.
pkg_check_modules(IMGUI REQUIRED IMPORTED_TARGET imgui)
find_package(Freetype REQUIRED)
# Debian builds toml++ as a shared library (TOML_HEADER_ONLY=0); the strings file is read with it.
find_package(tomlplusplus REQUIRED CONFIG)

add_library(glint_ui_screens STATIC imgui_layer.cpp strings.cpp screens.cpp)
# Imported targets' include directories are SYSTEM includes: ImGui's and FreeType's headers do not
# trip our warnings, which stay on for our files.
target_link_libraries(glint_ui_screens PUBLIC glint_gl glint_core PkgConfig::IMGUI
                      PRIVATE Freetype::Freetype tomlplusplus::tomlplusplus glint_warnings glint_tuning)
