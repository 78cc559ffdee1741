# `shrefract render` end to end (ctest runs this with -P): bake a tiny field of builtin:sphere,
# render it in Field mode with timings (lat-long and cube-map environments), render the built-in
# scene itself, and check that bad input fails with the documented exit codes. A tiny clustered Pca
# field (one index a sample, field format 6) is baked, described, rendered and, where
# DECOMPRESSION_BENCHMARK names the benchmark, timed by it (the path that reads a field file).
# Inputs: SHREFRACT (the tool), WORK_DIR, DECOMPRESSION_BENCHMARK (optional). Prints "SKIPPED: no Vulkan device" (ctest's
# SKIP_REGULAR_EXPRESSION) when no device exists.
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})

function(run expected_rc)
  execute_process(COMMAND ${SHREFRACT} ${ARGN} WORKING_DIRECTORY ${WORK_DIR}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL expected_rc)
    if(rc EQUAL 3)  # the tool's exit status for "no Vulkan device" (samples/cli/commands.h)
      if(REQUIRE_GPU)
        message(FATAL_ERROR "no Vulkan device, and SHREFRACT_REQUIRE_GPU is on: ${err}")
      endif()
      message("SKIPPED: no Vulkan device: ${err}")
      set(SKIP TRUE PARENT_SCOPE)
      return()
    endif()
    string(REPLACE ";" " " command "${ARGN}")
    message(FATAL_ERROR "shrefract ${command}: exit ${rc}, expected ${expected_rc}\nstdout: ${out}\nstderr: ${err}")
  endif()
  set(OUT "${out}" PARENT_SCOPE)
  set(ERR "${err}" PARENT_SCOPE)
endfunction()

run(0 bake builtin:sphere -o tiny.shrf --order 2 --directions 8x16 --samples 1000 --tessellation 2 --threads 2 --held-out 0)

run(0 render tiny.shrf -o field.png --size 96x72 --frames 3 --absorption 0.5 --json)
if(SKIP)
  return()
endif()
# "field" names the mode of every encoding; the field's own encoding is in its object.
foreach(key "\"mode\": \"field\"" "\"encoding\": \"sh\"" "\"frames\": 3" "\"gpu_ms\"" "\"wall_ms\"" "\"order\": 2")
  string(FIND "${OUT}" "${key}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "render --json output lacks ${key}: ${OUT}")
  endif()
endforeach()
run(0 render tiny.shrf -o field_cube.exr --size 96x72 --cube-env)
# "sh", the mode's name before fields had other encodings, still renders a field; the summary
# names the encoding.
run(0 render tiny.shrf -o field_sh.png --size 96x72 --mode sh)
string(FIND "${OUT}" "(96x72, field, sh," at)
if(at EQUAL -1)
  message(FATAL_ERROR "render's summary does not name the field's encoding: ${OUT}")
endif()
run(0 render tiny.shrf -o field_si.png --size 96x72 --mode single-interface --eye 0,0.5,4 --target 0,0,0)
run(0 render builtin:sphere -o scene.png --size 96x72)
foreach(image field.png field_cube.exr field_si.png scene.png)
  if(NOT EXISTS ${WORK_DIR}/${image})
    message(FATAL_ERROR "shrefract render did not write ${image}")
  endif()
endforeach()

# Usage errors exit 2; bad data exits 1 and names the file.
run(2 render builtin:sphere -o x.png --mode field)
run(2 render tiny.shrf -o x.png --ior 1.3)
file(WRITE ${WORK_DIR}/corrupt.shrf "not a field")
run(1 render corrupt.shrf -o x.png)
string(FIND "${ERR}" "corrupt.shrf" at)
if(at EQUAL -1)
  message(FATAL_ERROR "the error for a corrupt field does not name the file: ${ERR}")
endif()
if(EXISTS ${WORK_DIR}/x.png)
  message(FATAL_ERROR "a failed render left an image behind")
endif()

# A clustered Pca field: the sphere's 16 clusters decode its views closer than 16 components.
run(0 bake builtin:sphere -o clustered.shrf --encoding pca --table-size 12 --components 16 --samples 1000
    --tessellation 2 --threads 2 --held-out 0)
run(0 info clustered.shrf --json)
foreach(key "\"clustered\": true" "\"bytes_per_sample\": 2" "\"components\": 16")
  string(FIND "${OUT}" "${key}" at)
  if(at EQUAL -1)
    message(FATAL_ERROR "info --json of the clustered field lacks ${key}: ${OUT}")
  endif()
endforeach()
run(0 render clustered.shrf -o clustered.png --size 96x72 --spp 4)
if(NOT EXISTS ${WORK_DIR}/clustered.png)
  message(FATAL_ERROR "shrefract render did not write clustered.png")
endif()
if(DECOMPRESSION_BENCHMARK)
  execute_process(COMMAND ${DECOMPRESSION_BENCHMARK} clustered.shrf --reps 2 --validation WORKING_DIRECTORY ${WORK_DIR}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  string(FIND "${out}" "pca clustered K=16" at)
  if(NOT rc EQUAL 0 OR at EQUAL -1)
    message(FATAL_ERROR "shrefract_decompression_benchmark clustered.shrf: exit ${rc}\nstdout: ${out}\nstderr: ${err}")
  endif()
endif()
message("render command: all checks passed")
