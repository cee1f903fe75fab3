# hapticd_fuzz_target(): one libFuzzer entry point (LLVMFuzzerTestOneInput)
# per input format. Included from the top-level CMakeLists.txt before the
# drivers, so a driver's CMakeLists adds its codec target with one line:
#
#   hapticd_fuzz_target(canopen_sdo SOURCES fuzz/sdo_fuzz.cpp LIBS hapticd_driver_canopen
#                       SEEDS ${CMAKE_CURRENT_SOURCE_DIR}/fuzz/seeds)
#
# Every build makes fuzz_<name> and a CTest `fuzz_<name>_replay` (label
# fuzz) that runs tests/fuzz/regressions/<name>/ (every crasher ever found,
# kept after its fix) and the SEEDS once: with GCC through replay_main.cpp,
# in the sanitizer build (HAPTICD_FUZZ=ON, clang) through libFuzzer itself
# (-runs=0). tests/run_fuzz.sh fuzzes each target for a bounded time.
# docs/testing.md says how to write one and what to do with a crasher.
set(HAPTICD_FUZZ_DIR ${CMAKE_CURRENT_LIST_DIR})
define_property(GLOBAL PROPERTY HAPTICD_FUZZ_TARGETS BRIEF_DOCS "fuzz targets" FULL_DOCS "name|binary|seed dirs")

function(hapticd_fuzz_target name)
  if(NOT HAPTICD_TESTS)
    return()
  endif()
  cmake_parse_arguments(PARSE_ARGV 1 FUZZ "" "" "SOURCES;LIBS;SEEDS")
  set(target fuzz_${name})
  add_executable(${target} ${FUZZ_SOURCES})
  target_include_directories(${target} PRIVATE ${PROJECT_SOURCE_DIR})
  target_link_libraries(${target} PRIVATE ${FUZZ_LIBS} hapticd_warnings)
  if(HAPTICD_FUZZ)
    target_link_options(${target} PRIVATE -fsanitize=fuzzer)
  else()
    target_sources(${target} PRIVATE ${HAPTICD_FUZZ_DIR}/replay_main.cpp)
  endif()
  set(regressions ${HAPTICD_FUZZ_DIR}/regressions/${name})
  file(MAKE_DIRECTORY ${regressions})
  set(inputs ${regressions})
  foreach(dir IN LISTS FUZZ_SEEDS)
    if(EXISTS ${dir})
      list(APPEND inputs ${dir})
    endif()
  endforeach()
  if(HAPTICD_FUZZ)
    add_test(NAME fuzz_${name}_replay COMMAND ${target} -runs=0 ${inputs})
  else()
    add_test(NAME fuzz_${name}_replay COMMAND ${target} ${inputs})
  endif()
  set_tests_properties(fuzz_${name}_replay PROPERTIES LABELS fuzz)
  list(JOIN inputs "," joined)
  set_property(GLOBAL APPEND PROPERTY HAPTICD_FUZZ_TARGETS "${name}|$<TARGET_FILE:${target}>|${joined}")
endfunction()

# The list tests/run_fuzz.sh works through: one line per target,
# name|binary|regressions,seed,dirs. Call once, at the end of the top level.
function(hapticd_write_fuzz_list)
  get_property(targets GLOBAL PROPERTY HAPTICD_FUZZ_TARGETS)
  list(JOIN targets "\n" content)
  file(GENERATE OUTPUT ${PROJECT_BINARY_DIR}/fuzz_targets.txt CONTENT "${content}\n")
endfunction()
