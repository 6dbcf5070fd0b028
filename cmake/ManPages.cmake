# Man pages of the installed executables, made by help2man from each one's --help (and each
# subcommand's; packaging/man/make_man_page.py), gzipped, installed to <prefix>/share/man/man1.
# They run the executables at build time, so they are made only when the build can run what it
# builds (not when cross-compiling without an emulator) and help2man is there
# (scripts/install-deps.sh installs it). Without them `cmake --install` and the .deb have no
# man pages, and the package test (tests/package) fails on that.
find_program(GLINT_HELP2MAN help2man)
find_package(Python3 COMPONENTS Interpreter)
if(NOT GLINT_HELP2MAN OR NOT Python3_Interpreter_FOUND)
  message(WARNING "help2man or python3 not found: no man pages (scripts/install-deps.sh installs them)")
  return()
endif()
if(CMAKE_CROSSCOMPILING AND NOT CMAKE_CROSSCOMPILING_EMULATOR)
  message(STATUS "cross-compiling without an emulator: no man pages")
  return()
endif()

set(glint_man_summary_glint "light virtual objects with the captured light of the room (the Glint kiosk and its tools)")
set(glint_man_summary_glint-vision "Glint's camera commands (simulate, capture, calibrate, cameras, track, replay, run)")
set(glint_man_summary_glint-recording "inspect, play, verify and generate Glint's recorded sensor files")
set(glint_man_summary_glint-sensor-sim "Glint's sensor-board firmware on the host, on a pseudo-terminal")

set(glint_man_pages)
foreach(tool glint glint-vision glint-recording glint-sensor-sim)
  set(page ${CMAKE_CURRENT_BINARY_DIR}/man/${tool}.1.gz)
  add_custom_command(
    OUTPUT ${page}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${CMAKE_CURRENT_BINARY_DIR}/man
    COMMAND ${Python3_EXECUTABLE} ${PROJECT_SOURCE_DIR}/packaging/man/make_man_page.py
            --exe $<TARGET_FILE:${tool}> --name "${glint_man_summary_${tool}}" --version ${PROJECT_VERSION}
            --out ${page}
    # glint's page holds glint-vision's commands' help too (glint runs glint-vision for them).
    DEPENDS ${tool} glint-vision ${PROJECT_SOURCE_DIR}/packaging/man/make_man_page.py
            ${PROJECT_SOURCE_DIR}/packaging/man/${tool}.h2m
    COMMENT "Man page of ${tool} (help2man)"
    VERBATIM)
  list(APPEND glint_man_pages ${page})
endforeach()
add_custom_target(glint_man_pages ALL DEPENDS ${glint_man_pages})
install(FILES ${glint_man_pages} DESTINATION ${CMAKE_INSTALL_MANDIR}/man1)
