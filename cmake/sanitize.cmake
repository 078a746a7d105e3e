# Sanitizer build (scripts/test --sanitize): AddressSanitizer + UndefinedBehaviorSanitizer over
# the library, the CLI, the tests, the benchmarks and the Python module. Included before any
# target is defined so that every target (and every subdirectory) is instrumented.
#
# -fno-sanitize-recover: undefined behaviour aborts the test that hit it instead of printing a
# line nobody reads. Assertions stay on (NDEBUG is dropped) so Eigen's index checks run too: they
# see out-of-range rows inside one allocation, which ASan cannot.
option(GSHELL_SANITIZE "Build everything with -fsanitize=address,undefined (see scripts/test --sanitize)" OFF)
if(GSHELL_SANITIZE)
  set(_gshell_sanitize_flags -fsanitize=address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer)
  add_compile_options(${_gshell_sanitize_flags} -g1) # -g1: line numbers in reports, little cost
  add_link_options(${_gshell_sanitize_flags})
  foreach(_config RELEASE RELWITHDEBINFO MINSIZEREL)
    string(REPLACE "-DNDEBUG" "" CMAKE_CXX_FLAGS_${_config} "${CMAKE_CXX_FLAGS_${_config}}")
  endforeach()
  # The Python module is instrumented but python3 is not: the ASan runtime must be loaded first
  # (LD_PRELOAD), and CPython's own allocations that live until exit are not leaks of ours.
  execute_process(COMMAND ${CMAKE_CXX_COMPILER} -print-file-name=libasan.so
                  OUTPUT_VARIABLE _gshell_libasan OUTPUT_STRIP_TRAILING_WHITESPACE)
  if(CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    execute_process(COMMAND ${CMAKE_CXX_COMPILER} -print-file-name=libclang_rt.asan-x86_64.so
                    OUTPUT_VARIABLE _gshell_libasan OUTPUT_STRIP_TRAILING_WHITESPACE)
  endif()
  # libstdc++ goes in with it: python3 does not link it, and ASan's __cxa_throw interceptor finds
  # the real one only if libstdc++ is loaded when the runtime starts (else the first C++ throw in
  # the module aborts with "real___cxa_throw != 0").
  execute_process(COMMAND ${CMAKE_CXX_COMPILER} -print-file-name=libstdc++.so.6
                  OUTPUT_VARIABLE _gshell_libstdcxx OUTPUT_STRIP_TRAILING_WHITESPACE)
  get_filename_component(_gshell_libstdcxx "${_gshell_libstdcxx}" REALPATH)
  set(GSHELL_PYTHON_TEST_ENVIRONMENT "LD_PRELOAD=${_gshell_libasan}:${_gshell_libstdcxx};ASAN_OPTIONS=detect_leaks=0")
  message(STATUS "gshell: sanitizer build (ASan + UBSan); Python tests preload ${_gshell_libasan}")
endif()

# Fuzz build (scripts/fuzz): clang's libFuzzer coverage instrumentation plus ASan + UBSan over
# the library; fuzz/CMakeLists.txt links the targets with -fsanitize=fuzzer.
option(GSHELL_FUZZ "Build the libFuzzer targets in fuzz/ (needs clang; see scripts/fuzz)" OFF)
if(GSHELL_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "GSHELL_FUZZ needs clang (libFuzzer), e.g. CXX=clang++-14")
  endif()
  set(_gshell_fuzz_flags -fsanitize=fuzzer-no-link,address,undefined -fno-sanitize-recover=all -fno-omit-frame-pointer)
  add_compile_options(${_gshell_fuzz_flags} -g1)
  add_link_options(-fsanitize=address,undefined)
  foreach(_config RELEASE RELWITHDEBINFO MINSIZEREL)
    string(REPLACE "-DNDEBUG" "" CMAKE_CXX_FLAGS_${_config} "${CMAKE_CXX_FLAGS_${_config}}")
  endforeach()
endif()
