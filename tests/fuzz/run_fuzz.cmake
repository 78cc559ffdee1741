# ctest driver of the fuzz targets (tests/CMakeLists.txt, test `fuzz_test`): configures tests/fuzz
# as a project of its own with clang, builds it, writes fresh seeds, and runs every target for a
# few seconds on its corpus. Fails on any crash, sanitizer report, leak or timeout (libFuzzer exits
# non-zero and writes the input as WORK_DIR/crash-*). Without clang++ it prints "SKIPPED: ..." (a
# skip for ctest) unless REQUIRE_CLANG is set (scripts/setup-debian.sh installs clang, so CI
# requires it).
#
#   -DSOURCE_DIR=<repo> -DWORK_DIR=<dir> [-DSECONDS=5] [-DREQUIRE_CLANG=ON] [-DJOBS=2]
cmake_minimum_required(VERSION 3.25)
if(NOT SECONDS)
  set(SECONDS 5)
endif()
if(NOT JOBS)
  set(JOBS 2)
endif()

find_program(CLANGXX NAMES clang++ clang++-14 clang++-15 clang++-16)
if(NOT CLANGXX)
  if(REQUIRE_CLANG)
    message(FATAL_ERROR "fuzz_test: clang++ not found; scripts/setup-debian.sh installs clang and libclang-rt-14-dev")
  endif()
  message("SKIPPED: clang++ not found (libFuzzer needs clang; scripts/setup-debian.sh installs it)")
  return()
endif()

set(build ${WORK_DIR}/build)
execute_process(COMMAND ${CMAKE_COMMAND} -S ${SOURCE_DIR}/tests/fuzz -B ${build} -G Ninja
                        -DCMAKE_CXX_COMPILER=${CLANGXX} -DCMAKE_BUILD_TYPE=RelWithDebInfo
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "fuzz_test: configuring tests/fuzz failed:\n${out}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${build} -j ${JOBS}
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "fuzz_test: building the fuzz targets failed:\n${out}")
endif()

# Seeds: the committed corpus (read only) plus fresh ones in the current format.
file(MAKE_DIRECTORY ${WORK_DIR}/seeds/field ${WORK_DIR}/seeds/gltf)
execute_process(COMMAND ${build}/fuzz_seeds ${WORK_DIR}/seeds/field ${WORK_DIR}/seeds/gltf RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "fuzz_test: fuzz_seeds failed")
endif()

set(failed "")
foreach(target field gltf)
  # A fresh corpus per run, so every run starts from the seeds and stays short and reproducible.
  file(REMOVE_RECURSE ${WORK_DIR}/corpus/${target})
  file(MAKE_DIRECTORY ${WORK_DIR}/corpus/${target})
  execute_process(
    COMMAND ${build}/fuzz_${target} -max_total_time=${SECONDS} -timeout=10 -rss_limit_mb=2048 -seed=1
            -artifact_prefix=${WORK_DIR}/ -print_final_stats=1
            ${WORK_DIR}/corpus/${target} ${WORK_DIR}/seeds/${target} ${SOURCE_DIR}/tests/fuzz/corpus/${target}
    WORKING_DIRECTORY ${WORK_DIR}
    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE out)
  string(REGEX MATCH "stat::number_of_executed_units: *[0-9]+" runs "${out}")
  string(REGEX MATCHALL "cov: [0-9]+ ft: [0-9]+" coverage "${out}")
  if(coverage)
    list(GET coverage -1 coverage)  # the last report: the coverage at the end of the run
  endif()
  message("fuzz_${target}: ${SECONDS} s, ${runs}, ${coverage}, exit ${rc}")
  if(NOT rc EQUAL 0)
    string(LENGTH "${out}" length)
    if(length GREATER 6000)
      math(EXPR start "${length} - 6000")
      string(SUBSTRING "${out}" ${start} 6000 out)
    endif()
    message("${out}")
    list(APPEND failed fuzz_${target})
  endif()
endforeach()
if(failed)
  message(FATAL_ERROR "fuzz_test: ${failed} found a crash; the input is in ${WORK_DIR}/crash-* (rerun: "
                      "${build}/fuzz_TARGET ${WORK_DIR}/crash-...)")
endif()
