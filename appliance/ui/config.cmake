# glint_ui_config: the kiosk's TOML configuration and its SIGHUP reload, the maintenance PIN and
# the systemd notifications (docs/service.md). Kept free of GL, OpenCV and libcamera so that the
# small `glint` executable can read the config (and its tests build in seconds).
#   toml++      Debian's libtomlplusplus-dev 3.3 ships a compiled shared library (libtomlplusplus3)
#               and a CMake config; its target adds TOML_HEADER_ONLY=0.
#   libxcrypt   crypt_r, crypt_gensalt_rn, crypt_checksalt (libcrypt-dev, pkg-config libxcrypt)
#   libsystemd  sd_notify, sd_watchdog_enabled (libsystemd-dev, pkg-config libsystemd)
find_package(tomlplusplus 3.3 REQUIRED CONFIG)
find_package(PkgConfig REQUIRED)
pkg_check_modules(LIBXCRYPT REQUIRED IMPORTED_TARGET libxcrypt)
pkg_check_modules(LIBSYSTEMD REQUIRED IMPORTED_TARGET libsystemd)
add_library(glint_ui_config STATIC
  config.cpp
  config_reload.cpp
  pin_lock.cpp
  service_notify.cpp
)
target_include_directories(glint_ui_config PUBLIC ${PROJECT_SOURCE_DIR})
target_link_libraries(glint_ui_config PUBLIC glint_core
                      PRIVATE glint_render_model tomlplusplus::tomlplusplus PkgConfig::LIBXCRYPT PkgConfig::LIBSYSTEMD
                      glint_warnings glint_tuning)
