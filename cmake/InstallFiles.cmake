# What the appliance needs at run time besides the executables (docs/packaging.md, "What it
# installs"). Paths follow GNUInstallDirs under CMAKE_INSTALL_PREFIX, except the systemd, udev,
# sysusers and tmpfiles files, which go where systemd looks for a package's files
# (<prefix>/lib/..., not the multiarch LIBDIR), and the configuration, which goes to /etc when
# the prefix is /usr (as GNUInstallDirs does for SYSCONFDIR).
#
# Not installed because they are not files at run time: the shaders (embedded into the binary,
# cmake/EmbedShaders.cmake), the teapot (made from its Bezier patches in code) and its ambient
# occlusion (baked when the kiosk starts). The font is Debian's (fonts-dejavu-core, read from
# /usr/share/fonts/truetype/dejavu/), a dependency of the package, not a copy.

set(glint_datadir ${CMAKE_INSTALL_DATADIR}/glint)

# find_data_file (appliance/app/cli_util.cpp) looks for "data/..." under <bindir>/../share/glint.
install(FILES ${PROJECT_SOURCE_DIR}/data/ui/strings.toml DESTINATION ${glint_datadir}/data/ui)
# The recorded kiosk session of the main job: `glint replay /usr/share/glint/data/sessions/kiosk
# --out DIR` checks an installed appliance's GL, tracking and rendering without a camera.
install(DIRECTORY ${PROJECT_SOURCE_DIR}/data/sessions/kiosk DESTINATION ${glint_datadir}/data/sessions)

# systemd: the unit, the service user and its groups, the state and export directories, the
# sensor's stable name and the GPIO/I2C groups.
set(glint_systemd_dir ${PROJECT_SOURCE_DIR}/systemd)
install(FILES ${glint_systemd_dir}/glint.service DESTINATION lib/systemd/system)
install(FILES ${glint_systemd_dir}/glint.sysusers DESTINATION lib/sysusers.d RENAME glint.conf)
install(FILES ${glint_systemd_dir}/glint.tmpfiles DESTINATION lib/tmpfiles.d RENAME glint.conf)
install(FILES ${glint_systemd_dir}/99-glint-sensor.rules ${glint_systemd_dir}/99-glint-gpio.rules
        DESTINATION lib/udev/rules.d)

# The configuration the unit reads (ExecStart=... --config /etc/glint/glint.toml): every key at
# its default. In the .deb it is a conffile (packaging/deb/conffiles), so an edited file survives
# upgrades. The destination is decided at install time, when CPack's prefix (/usr) is known.
install(CODE "
  if(CMAKE_INSTALL_PREFIX STREQUAL \"/usr\")
    set(glint_sysconfdir /etc)
  else()
    set(glint_sysconfdir \"\${CMAKE_INSTALL_PREFIX}/etc\")
  endif()
  file(INSTALL DESTINATION \"\${glint_sysconfdir}/glint\" TYPE FILE
       FILES \"${PROJECT_SOURCE_DIR}/config/glint.example.toml\" RENAME glint.toml)
")
# The same file as the documented example, untouched by edits of the live one.
install(FILES ${PROJECT_SOURCE_DIR}/config/glint.example.toml DESTINATION ${CMAKE_INSTALL_DOCDIR}/examples
        RENAME glint.toml)
install(FILES ${PROJECT_SOURCE_DIR}/docs/packaging.md ${PROJECT_SOURCE_DIR}/docs/service.md
        DESTINATION ${CMAKE_INSTALL_DOCDIR})
