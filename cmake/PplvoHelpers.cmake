# Small helpers shared by every folder's CMakeLists.

# Warnings for the project's own code (generated LCM code is left alone).
function(pplvo_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wshadow -Wnon-virtual-dtor
                         -Wno-unused-parameter
                         -Wno-maybe-uninitialized)  # false positives in lcm-gen decode()
endfunction()

# pplvo_test(NAME SOURCES... LIBS libs... [LABELS labels...] [TIMEOUT s])
# A GoogleTest executable registered with ctest. Tests run from the source tree root so
# they can reach ../shared/data relative to it.
function(pplvo_test name)
  cmake_parse_arguments(T "" "TIMEOUT" "SOURCES;LIBS;LABELS" ${ARGN})
  if(NOT PPLVO_BUILD_TESTS)
    return()
  endif()
  add_executable(${name} ${T_SOURCES})
  target_link_libraries(${name} PRIVATE ${T_LIBS} GTest::gtest GTest::gtest_main)
  set_target_properties(${name} PROPERTIES PPLVO_TEST_CODE ON)  # may use fixtures/ (layering)
  pplvo_warnings(${name})
  if(NOT T_TIMEOUT)
    set(T_TIMEOUT 300)
  endif()
  if(NOT T_LABELS)
    set(T_LABELS unit)
  endif()
  add_test(NAME ${name} COMMAND ${name} WORKING_DIRECTORY ${PROJECT_SOURCE_DIR})
  set_tests_properties(${name} PROPERTIES TIMEOUT ${T_TIMEOUT} LABELS "${T_LABELS}"
    ENVIRONMENT "PPLVO_SOURCE_DIR=${PROJECT_SOURCE_DIR};PPLVO_BINARY_DIR=${PROJECT_BINARY_DIR};PPLVO_SHARED_DATA=${PROJECT_SOURCE_DIR}/../shared/data;LCM_DEFAULT_URL=memq://")
endfunction()

# pplvo_benchmark(NAME SOURCES... LIBS libs...): a Google Benchmark program, not run by ctest.
function(pplvo_benchmark name)
  cmake_parse_arguments(B "" "" "SOURCES;LIBS" ${ARGN})
  if(NOT PPLVO_BUILD_BENCHMARKS OR NOT benchmark_FOUND)
    return()
  endif()
  add_executable(${name} ${B_SOURCES})
  target_link_libraries(${name} PRIVATE ${B_LIBS} benchmark::benchmark)
  set_target_properties(${name} PROPERTIES PPLVO_TEST_CODE ON)  # may use fixtures/ (layering)
  pplvo_warnings(${name})
endfunction()
