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
