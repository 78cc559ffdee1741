# The frame benchmark's --env-taps and --msaa (docs/performance.md, "Frame"): bad values are usage
# errors (one line naming the flag, exit 2, before any device is touched); a good tap list runs
# every series once per count and prints each count's raster time against the first's, --msaa 4
# runs them again at 4 samples and prints those against one sample, with 0 validation messages.
# Inputs: FRAME_BENCHMARK. Prints "SKIPPED: no Vulkan device" (ctest's SKIP_REGULAR_EXPRESSION)
# when the benchmark finds no device.
function(run expected_rc)
  execute_process(COMMAND ${FRAME_BENCHMARK} ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  string(REPLACE ";" " " command "${ARGN}")
  if(NOT rc EQUAL expected_rc)
    message(FATAL_ERROR "shrefract_frame_benchmark ${command}: exit ${rc}, expected ${expected_rc}\nstdout: ${out}\nstderr: ${err}")
  endif()
  set(OUT "${out}" PARENT_SCOPE)
  set(ERR "${err}" PARENT_SCOPE)
endfunction()

foreach(bad "0" "5" "1," ",2" "1,,2" "x" "2x" "-1" "")
  run(2 --env-taps "${bad}")
  string(STRIP "${ERR}" line)
  if(NOT line MATCHES "^shrefract_frame_benchmark: --env-taps expects" OR line MATCHES "\n")
    message(FATAL_ERROR "--env-taps '${bad}': expected one line naming the flag, got: ${ERR}")
  endif()
endforeach()
run(2 --env-taps)  # the value missing
foreach(bad "0" "3" "16" "x" "")
  run(2 --msaa "${bad}")
  string(STRIP "${ERR}" line)
  if(NOT line MATCHES "^shrefract_frame_benchmark: --msaa expects" OR line MATCHES "\n")
    message(FATAL_ERROR "--msaa '${bad}': expected one line naming the flag, got: ${ERR}")
  endif()
endforeach()

run(0 --env-taps 1,2 --msaa 4 --instances 1 --size 64x48 --frames 2 --validation)
if(OUT MATCHES "SKIPPED: no Vulkan device")
  message("${OUT}")
  return()
endif()
foreach(expected "environment taps per axis: 1" "environment taps per axis: 2"
                 "environment taps, ratios to 1 taps per axis" "2 / 1 taps, still eye, 1 instance"
                 "4 sample(s) per pixel" "MSAA, 4x against 1 sample per pixel" "2 taps, still eye, 1 instance")
  string(FIND "${OUT}" "${expected}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "--env-taps 1,2 --msaa 4: the output lacks '${expected}':\n${OUT}")
  endif()
endforeach()
