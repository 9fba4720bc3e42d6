# Helpers shared by every component's CMakeLists.txt.

# Add every direct subfolder of DIR that has a CMakeLists.txt, in name order.
# HARVEST_ONLY (a ;-list of folder names, e.g. "runtime;config;vision")
# restricts the build to those folders, for partial builds on one machine.
set(HARVEST_ONLY "" CACHE STRING "Build only these lib/processes/tests folders (default: all)")
function(harvest_add_subdirectories dir)
  file(GLOB children RELATIVE ${CMAKE_CURRENT_SOURCE_DIR}/${dir} ${CMAKE_CURRENT_SOURCE_DIR}/${dir}/*)
  list(SORT children)
  foreach(child IN LISTS children)
    if(HARVEST_ONLY AND NOT child IN_LIST HARVEST_ONLY)
      continue()
    endif()
    if(EXISTS ${CMAKE_CURRENT_SOURCE_DIR}/${dir}/${child}/CMakeLists.txt)
      add_subdirectory(${dir}/${child})
    endif()
  endforeach()
endfunction()

# harvest_library(NAME SOURCES ... [DEPS ...])
# A static library harvest_<NAME>; headers are included as "<folder>/<file>.hpp"
# relative to lib/.
function(harvest_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_library(harvest_${name} STATIC ${ARG_SOURCES})
  target_include_directories(harvest_${name} PUBLIC ${PROJECT_SOURCE_DIR}/lib)
  target_link_libraries(harvest_${name} PUBLIC ${ARG_DEPS} PRIVATE harvest_warnings)
  set_target_properties(harvest_${name} PROPERTIES POSITION_INDEPENDENT_CODE ON)
endfunction()

# harvest_process(NAME SOURCES ... [DEPS ...]): an executable bin/NAME.
function(harvest_process name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} harvest_warnings)
endfunction()

# harvest_test(NAME SOURCES ... [DEPS ...] [LABELS L] [RESOURCE_LOCK NAME] [RUN_SERIAL]):
# a GoogleTest binary registered with CTest. Tests run from the source root so
# fixtures can be found as config/..., logs/... Tests holding the same
# RESOURCE_LOCK never run at the same time under ctest -j. One label only:
# gtest_discover_tests (CMake 3.25) writes a list-valued property unquoted,
# and the properties after it (TIMEOUT, RESOURCE_LOCK) were lost. ctest -L
# takes a regular expression: -L integration selects integration-realtime.
# RUN_SERIAL: no other test runs beside it (a test that loads the machine on
# purpose and needs to know how much).
function(harvest_test name)
  cmake_parse_arguments(ARG "RUN_SERIAL" "TIMEOUT;RESOURCE_LOCK" "SOURCES;DEPS;LABELS" ${ARGN})
  if(NOT ARG_LABELS)
    set(ARG_LABELS unit)
  endif()
  list(LENGTH ARG_LABELS n_labels)
  if(n_labels GREATER 1)
    message(FATAL_ERROR "harvest_test(${name}): one label only (e.g. integration-realtime), got '${ARG_LABELS}'")
  endif()
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 120)
  endif()
  # Real-time tests measure deadlines and whole process sets: one at a time
  # (beside the rest of the suite), or they starve each other on 2 cores.
  if(ARG_LABELS STREQUAL "integration-realtime" AND NOT ARG_RESOURCE_LOCK)
    set(ARG_RESOURCE_LOCK harvest_realtime)
  endif()
  set(lock "")
  if(ARG_RESOURCE_LOCK)
    set(lock RESOURCE_LOCK ${ARG_RESOURCE_LOCK})
  endif()
  if(ARG_RUN_SERIAL)
    list(APPEND lock RUN_SERIAL TRUE)
  endif()
  add_executable(${name} ${ARG_SOURCES})
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests)
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gmock GTest::gtest_main harvest_warnings)
  # No build paths compiled into test objects (they would differ per checkout
  # and defeat ccache across worktrees): tests run from the source tree
  # (WORKING_DIRECTORY) and find executables through harvest_test_support.
  gtest_discover_tests(${name}
    WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
    DISCOVERY_MODE PRE_TEST
    PROPERTIES LABELS "${ARG_LABELS}" TIMEOUT ${ARG_TIMEOUT} ${lock})
endfunction()

# harvest_benchmark(NAME SOURCES ... [DEPS ...]): a Google Benchmark binary in
# build/bench (not run by ctest; see tools/harvest bench).
function(harvest_benchmark name)
  if(NOT HARVEST_BENCHMARKS)
    return()
  endif()
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bench)
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} benchmark::benchmark harvest_warnings)
  target_compile_definitions(${name} PRIVATE HARVEST_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
endfunction()

# harvest_fuzz_target(NAME SOURCES ... [DEPS ...] CORPUS DIR)
# A fuzz target is a LLVMFuzzerTestOneInput in SOURCES, built twice:
# * always, linked with tests/fuzz/replay_main.cpp into tests/NAME_replay,
#   which ctest runs once over every file of the committed corpus DIR
#   (test fuzz_corpus.NAME, labels unit and fuzz), so every build, gcc
#   included, replays the corpora;
# * with -DHARVEST_FUZZ=ON (clang only), as the libFuzzer binary fuzz/NAME
#   with ASan and UBSan for campaigns (docs/fuzzing.md).
function(harvest_fuzz_target name)
  cmake_parse_arguments(ARG "" "CORPUS" "SOURCES;DEPS" ${ARGN})
  add_executable(${name}_replay ${ARG_SOURCES} ${PROJECT_SOURCE_DIR}/tests/fuzz/replay_main.cpp)
  set_target_properties(${name}_replay PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests)
  target_link_libraries(${name}_replay PRIVATE ${ARG_DEPS} harvest_warnings)
  add_test(NAME fuzz_corpus.${name} COMMAND ${name}_replay ${ARG_CORPUS} WORKING_DIRECTORY ${PROJECT_SOURCE_DIR})
  set_tests_properties(fuzz_corpus.${name} PROPERTIES LABELS "unit;fuzz" TIMEOUT 300)
  if(HARVEST_FUZZ)
    add_executable(${name} ${ARG_SOURCES})
    target_link_options(${name} PRIVATE -fsanitize=fuzzer)
    target_link_libraries(${name} PRIVATE ${ARG_DEPS} harvest_warnings)
    set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/fuzz)
  endif()
endfunction()

# harvest_generate_from_lcmtypes(OUTPUT <header> SCRIPT <generator.py> COMMENT <text>): a header generated from the
# message contract (lcmtypes/*.lcm, parsed by lcmtypes/lcm_schema.py); the generator is called as
# `SCRIPT OUTPUT LCM_FILES...` and re-run when either the script, the parser or a .lcm file changes.
function(harvest_generate_from_lcmtypes)
  cmake_parse_arguments(G "" "OUTPUT;SCRIPT;COMMENT" "" ${ARGN})
  find_program(HARVEST_PYTHON3 python3 REQUIRED)
  file(GLOB lcm_files CONFIGURE_DEPENDS ${PROJECT_SOURCE_DIR}/lcmtypes/*.lcm)
  list(SORT lcm_files)
  get_filename_component(out_dir ${G_OUTPUT} DIRECTORY)
  add_custom_command(
    OUTPUT ${G_OUTPUT}
    COMMAND ${CMAKE_COMMAND} -E make_directory ${out_dir}
    COMMAND ${HARVEST_PYTHON3} ${G_SCRIPT} ${G_OUTPUT} ${lcm_files}
    DEPENDS ${G_SCRIPT} ${PROJECT_SOURCE_DIR}/lcmtypes/lcm_schema.py ${lcm_files}
    COMMENT "${G_COMMENT}")
endfunction()
