# mound_add_library(NAME SRCS ... DEPS ...): one static library per domain.
function(mound_add_library name)
  cmake_parse_arguments(ARG "" "" "SRCS;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(${name} STATIC ${ARG_SRCS})
  target_include_directories(${name} PUBLIC ${PROJECT_SOURCE_DIR}/cpp)
  target_compile_options(${name} PRIVATE -Wall -Wextra)
  target_link_libraries(${name} PUBLIC ${ARG_PUBLIC_DEPS} PRIVATE ${ARG_PRIVATE_DEPS})
endfunction()

# mound_add_test(DOMAIN NAME SRCS ... DEPS ...): a gtest binary registered with ctest as
# DOMAIN/NAME, so that `ctest -R tsp/` selects one domain (COLMAP's convention).
function(mound_add_test domain name)
  if(NOT MOUND_BUILD_TESTS)
    return()
  endif()
  cmake_parse_arguments(ARG "" "" "SRCS;DEPS" ${ARGN})
  set(target ${domain}_${name})
  add_executable(${target} ${ARG_SRCS})
  target_compile_options(${target} PRIVATE -Wall -Wextra)
  target_compile_definitions(${target} PRIVATE
    MOUND_SHARED_DATA="${MOUND_SHARED_DATA}"
    MOUND_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  target_link_libraries(${target} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gtest_main)
  add_test(NAME ${domain}/${name} COMMAND ${target})
  # `ctest -L sfm` runs one domain's tests; the whole ctest suite takes ~15 s.
  set_tests_properties(${domain}/${name} PROPERTIES LABELS ${domain})
endfunction()

# mound_add_fuzzer(NAME SRCS ... DEPS ...): a libFuzzer target `fuzz_NAME` (MOUND_FUZZ
# builds only); its sources live beside the reader they fuzz (*_fuzz.cc).
function(mound_add_fuzzer name)
  if(NOT MOUND_FUZZ)
    return()
  endif()
  cmake_parse_arguments(ARG "" "" "SRCS;DEPS" ${ARGN})
  add_executable(fuzz_${name} ${ARG_SRCS})
  target_compile_options(fuzz_${name} PRIVATE -Wall -Wextra)
  target_link_libraries(fuzz_${name} PRIVATE ${ARG_DEPS})
  target_link_options(fuzz_${name} PRIVATE -fsanitize=fuzzer)
  set_target_properties(fuzz_${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${PROJECT_BINARY_DIR}/fuzz)
endfunction()
