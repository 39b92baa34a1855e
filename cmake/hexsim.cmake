# Shared build helpers for hexsim's folders.

set(HEXSIM_SOURCE_DIR ${CMAKE_CURRENT_SOURCE_DIR})

# Unity (jumbo) build: each target compiles its sources as a few translation units of up to
# HEXSIM_UNITY_BATCH files (CMake's UNITY_BUILD), so Eigen, the standard library, nlohmann_json,
# fmt, yaml-cpp and gtest are parsed and their shared templates instantiated and optimised once per
# batch instead of once per file: the fresh release build and the sanitizer build cost about half the
# CPU time (bench/README.md "Build time"). clang-tidy needs one compile_commands.json entry per file:
# scripts/gates.sh tidy configures with -DHEXSIM_UNITY=OFF. A file whose internal (anonymous-namespace
# or static) names clash with another file of its target is kept out of the batches with
# hexsim_unity_apart() in its folder's CMakeLists.txt.
option(HEXSIM_UNITY "Unity build of hexsim's targets (one translation unit per HEXSIM_UNITY_BATCH files)" ON)
set(HEXSIM_UNITY_BATCH 16 CACHE STRING "Source files per unity translation unit (HEXSIM_UNITY)")
set(CMAKE_UNITY_BUILD ${HEXSIM_UNITY})
set(CMAKE_UNITY_BUILD_BATCH_SIZE ${HEXSIM_UNITY_BATCH})

# hexsim_unity_apart(FILE...): FILEs (relative to the calling CMakeLists.txt) compile on their own
# in a unity build, because an internal name in each also exists in another file of the same target.
# Call it in the directory that defines the target (source properties are per directory).
function(hexsim_unity_apart)
  set_source_files_properties(${ARGN} PROPERTIES SKIP_UNITY_BUILD_INCLUSION ON)
endfunction()

# Warnings (and -Werror in CI) for hexsim's own targets only.
function(hexsim_target_options target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Wno-unused-parameter)
  if(HEXSIM_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

if(HEXSIM_SANITIZE)
  add_compile_options(-fsanitize=address,undefined -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_link_options(-fsanitize=address,undefined)
endif()

# hexsim_library(NAME SOURCES ... DEPS ...): a folder's library, hexsim_<NAME>,
# with its public headers in <folder>/include.
function(hexsim_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(hexsim_${name} STATIC ${ARG_SOURCES})
  add_library(hexsim::${name} ALIAS hexsim_${name})
  target_include_directories(hexsim_${name} PUBLIC
    $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/include>
    $<INSTALL_INTERFACE:include>)
  target_link_libraries(hexsim_${name} PUBLIC ${ARG_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
  hexsim_target_options(hexsim_${name})
  if(HEXSIM_SANITIZE)
    # The archives hold instrumented code: whoever links them, also through the installed package
    # (the examples), needs the sanitizer runtimes, and must compile with the same flag: Eigen's
    # aligned allocator changes with __SANITIZE_ADDRESS__ (Memory.h), so a matrix freed by code
    # built without it crashes in ASan's free.
    target_compile_options(hexsim_${name} INTERFACE -fsanitize=address,undefined)
    target_link_options(hexsim_${name} INTERFACE -fsanitize=address,undefined)
  endif()
  # Installed as hexsim::<NAME> (cmake/hexsim_install.cmake writes the export and hexsimConfig.cmake).
  set_target_properties(hexsim_${name} PROPERTIES EXPORT_NAME ${name})
  install(TARGETS hexsim_${name} EXPORT hexsimTargets ARCHIVE DESTINATION lib LIBRARY DESTINATION lib)
  install(DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/include/ DESTINATION include)
endfunction()

# hexsim_test(NAME SOURCES ... DEPS ...): a GoogleTest executable registered with CTest.
function(hexsim_test name)
  if(NOT HEXSIM_BUILD_TESTS)
    return()
  endif()
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gtest_main)
  target_compile_definitions(${name} PRIVATE
    HEXSIM_SOURCE_DIR="${HEXSIM_SOURCE_DIR}"
    HEXSIM_BINARY_DIR="${CMAKE_BINARY_DIR}")
  hexsim_target_options(${name})
  gtest_discover_tests(${name} DISCOVERY_TIMEOUT 60
    PROPERTIES ENVIRONMENT "HEXSIM_DATA_DIR=${HEXSIM_SOURCE_DIR}")
endfunction()

# hexsim_folder(NAME DEPS ... [PRIVATE_DEPS ...] [TEST_DEPS ...]): the standard folder layout:
# src/*.cc -> library hexsim_<NAME>; test/*_test.cc -> one test executable <NAME>_test.
# New files are picked up without editing this file (CONFIGURE_DEPENDS).
function(hexsim_folder name)
  cmake_parse_arguments(ARG "" "" "DEPS;PRIVATE_DEPS;TEST_DEPS;EXTRA_SOURCES" ${ARGN})
  file(GLOB srcs CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/src/*.cc)
  list(APPEND srcs ${ARG_EXTRA_SOURCES})
  if(NOT srcs)
    return()
  endif()
  # A hexsim folder that has no sources yet is skipped, so its dependants still configure.
  set(deps "")
  foreach(d ${ARG_DEPS})
    if(d MATCHES "^hexsim::" AND NOT TARGET ${d})
      message(STATUS "hexsim: ${name}: ${d} not built (no sources yet)")
    else()
      list(APPEND deps ${d})
    endif()
  endforeach()
  hexsim_library(${name} SOURCES ${srcs} DEPS ${deps} PRIVATE_DEPS ${ARG_PRIVATE_DEPS})
  file(GLOB tests CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/test/*_test.cc)
  file(GLOB test_support CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/test/support/*.cc)
  if(tests AND HEXSIM_BUILD_TESTS)
    hexsim_test(${name}_test SOURCES ${tests} ${test_support} DEPS hexsim::${name} ${ARG_TEST_DEPS})
    target_include_directories(${name}_test PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/test)
  endif()
endfunction()
