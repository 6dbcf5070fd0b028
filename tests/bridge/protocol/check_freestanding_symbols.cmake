# Fails when the protocol library needs something a bare-metal build lacks: the heap, exception
# support, RTTI or stdio. Run as: cmake -DLIBRARY=lib.a -DNM=nm -P check_freestanding_symbols.cmake
execute_process(COMMAND ${NM} -u -C ${LIBRARY} OUTPUT_VARIABLE undefined RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "nm failed on ${LIBRARY}")
endif()
set(forbidden "operator new" "operator delete" "malloc" "calloc" "realloc" "free" "__cxa_throw"
    "__cxa_allocate_exception" "__cxa_begin_catch" "typeinfo" "__dynamic_cast" "printf" "puts"
    "fopen" "fwrite" "std::__throw" "abort")
string(REPLACE "\n" ";" lines "${undefined}")
set(bad "")
foreach(line ${lines})
  # A sanitizer build (scripts/run-sanitizers.sh) instruments the library: its calls into the
  # ASan/UBSan runtime (__asan_stack_malloc_N for the fake stack, ...) are the instrumentation's,
  # not the code's, and a firmware build has none.
  if(line MATCHES "__(asan|ubsan|lsan)_")
    continue()
  endif()
  foreach(word ${forbidden})
    string(FIND "${line}" "${word}" at)
    if(NOT at EQUAL -1)
      list(APPEND bad "${line}")
    endif()
  endforeach()
endforeach()
if(bad)
  message(FATAL_ERROR "${LIBRARY} needs symbols a microcontroller build lacks:\n${bad}")
endif()
message(STATUS "${LIBRARY}: undefined symbols are freestanding-safe:\n${undefined}")
