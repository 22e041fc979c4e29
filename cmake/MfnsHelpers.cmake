# Shared build helpers: warning flags, flight-code flags, test registration.

# Warnings for MFNS's own code (third-party headers come in as SYSTEM includes).
function(mfns_warnings target)
  target_compile_options(${target} PRIVATE
    -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wcast-align
    -Wunused -Woverloaded-virtual -Wdouble-promotion -Wformat=2
    -Wimplicit-fallthrough -Wsign-conversion)
  if(MFNS_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

# Unity builds (CMAKE_UNITY_BUILD, on in the host and host-asan presets: their builds are most
# of CI's time; the aarch64 flight build stays file by file) merge a target's sources into one
# translation unit, which parses the shared headers once. A target of one source gains nothing, and a file whose types with linkage hold types of
# its anonymous namespace (detect.cc's workspace) would then warn as a header does
# (-Wsubobject-linkage): such targets stay file by file.
function(mfns_unity_sources target)
  list(LENGTH ARGN _mfns_n)
  if(_mfns_n LESS 2)
    set_target_properties(${target} PROPERTIES UNITY_BUILD OFF)
  endif()
endfunction()

# Code that runs on the flyer (common/ and firmware/ libraries): no exceptions, no RTTI.
function(mfns_flight_code target)
  mfns_warnings(${target})
  target_compile_options(${target} PRIVATE -fno-exceptions -fno-rtti)
endfunction()

# mfns_flight_library(NAME SOURCES ... DEPS ...): a static library of flight code whose
# include root is the repository root (#include "common/rotation/rotation.h").
function(mfns_flight_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_library(${name} STATIC ${ARG_SOURCES})
  mfns_unity_sources(${name} ${ARG_SOURCES})
  target_include_directories(${name} PUBLIC ${PROJECT_SOURCE_DIR})
  target_link_libraries(${name} PUBLIC Eigen3::Eigen ${ARG_DEPS})
  mfns_flight_code(${name})
endfunction()

# mfns_host_library(NAME SOURCES ... DEPS ...): a host-only library (may allocate, may throw).
function(mfns_host_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_library(${name} STATIC ${ARG_SOURCES})
  mfns_unity_sources(${name} ${ARG_SOURCES})
  target_include_directories(${name} PUBLIC ${PROJECT_SOURCE_DIR})
  target_link_libraries(${name} PUBLIC Eigen3::Eigen ${ARG_DEPS})
  mfns_warnings(${name})
endfunction()

# mfns_gtest(NAME SOURCES ... DEPS ... [LABELS ...] [COST seconds]): a GoogleTest binary
# registered with CTest. COST (the seconds its longest test takes) makes ctest -j start its
# tests first: a fresh build has no timing history, and a long test started last runs alone
# on one core at the end of the stage.
# Tests are discovered when ctest runs (PRE_TEST), so cross builds need no emulator at build
# time; under the aarch64 preset CTest runs them through CMAKE_CROSSCOMPILING_EMULATOR.
# SHARED_SETUP suite ...: each of these suites runs as one CTest test ("Suite.*", one process)
# instead of one process per test: their SetUpTestSuite renders a dataset, which one process per
# test repeated for every test (RigCommandTest: 10 times). A skipped test marks it skipped.
function(mfns_gtest name)
  cmake_parse_arguments(ARG "" "COST" "SOURCES;DEPS;LABELS;SHARED_SETUP" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  mfns_unity_sources(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gmock GTest::gtest_main)
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR})
  mfns_warnings(${name})
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests)
  set(_mfns_filter "")
  if(ARG_SHARED_SETUP)
    list(TRANSFORM ARG_SHARED_SETUP APPEND ".*" OUTPUT_VARIABLE _mfns_suites)
    list(JOIN _mfns_suites ":" _mfns_suites)
    set(_mfns_filter "-${_mfns_suites}")
  endif()
  gtest_discover_tests(${name}
    DISCOVERY_MODE PRE_TEST
    DISCOVERY_TIMEOUT 120
    TEST_FILTER "${_mfns_filter}"
    WORKING_DIRECTORY ${CMAKE_BINARY_DIR}
    PROPERTIES ENVIRONMENT "MFNS_SOURCE_DIR=${PROJECT_SOURCE_DIR}")
  foreach(_mfns_suite IN LISTS ARG_SHARED_SETUP)
    add_test(NAME ${_mfns_suite}.* COMMAND ${name} --gtest_filter=${_mfns_suite}.* WORKING_DIRECTORY ${CMAKE_BINARY_DIR})
    set_tests_properties(${_mfns_suite}.* PROPERTIES ENVIRONMENT "MFNS_SOURCE_DIR=${PROJECT_SOURCE_DIR}"
                         LABELS "${ARG_LABELS}" SKIP_REGULAR_EXPRESSION "\\[  SKIPPED \\]")
    if(ARG_COST)
      set_tests_properties(${_mfns_suite}.* PROPERTIES COST ${ARG_COST})
    endif()
  endforeach()
  # Labels are set by a CTest include file that runs after the discovered tests are added:
  # gtest_discover_tests flattens its PROPERTIES, so a label list ("host;slow") passed there
  # would split into LABELS=host and a stray property.
  set(_mfns_label_file ${CMAKE_CURRENT_BINARY_DIR}/${name}_labels.cmake)
  set(_mfns_cost "")
  if(ARG_COST)
    set(_mfns_cost " COST ${ARG_COST}")
  endif()
  file(WRITE ${_mfns_label_file}
       "if(DEFINED ${name}_TESTS)\n  set_tests_properties(\${${name}_TESTS} PROPERTIES LABELS \"${ARG_LABELS}\"${_mfns_cost})\nendif()\n")
  set_property(DIRECTORY APPEND PROPERTY TEST_INCLUDE_FILES ${_mfns_label_file})
endfunction()

# mfns_benchmark(NAME SOURCES ... DEPS ...): a Google Benchmark program in bin/ (not a test).
# Benchmarks measure speed; their numbers go to docs/benchmarks.md with the command used.
function(mfns_benchmark name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  if(NOT MFNS_BUILD_BENCHMARKS)
    return()
  endif()
  find_package(benchmark REQUIRED)
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} benchmark::benchmark)
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR})
  mfns_warnings(${name})
endfunction()
