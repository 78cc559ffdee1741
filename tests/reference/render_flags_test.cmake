# `shrefract render` supersampling and path flags: --spp (a perfect square 1..64, every mode),
# --path-rule (exact mode), --msaa (GPU modes: 1, 2, 4 or 8, a count the device lacks refused
# naming the flag), --volume-per-fragment (field mode of a volume field), and the developer options
# (--dev KEY=VALUE) of the references: throughput (exact mode), filtered (exact and full-tree),
# env-taps (GPU modes, and CPU modes with filtered), env-level-bias (CPU modes with filtered),
# no-volume-refine (only with --volume-per-fragment), no-refine (full-tree with filtered; the JSON
# summary counts the refined sub-samples). Range and usage errors exit 2 with one line naming the
# flag (`--dev KEY` for an option) and write nothing; good values render (CPU modes always; the GPU
# case skips without a device, printing "SKIPPED: no Vulkan device"). Inputs: SHREFRACT (the tool),
# WORK_DIR.
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
set(base render builtin:sphere --tessellation 1 -o ${WORK_DIR}/out.png)

# expect_usage_error(FLAG SIZE ARGS...): `render ... --size SIZE ARGS` must fail naming FLAG.
function(expect_usage_error flag size)
  execute_process(COMMAND ${SHREFRACT} ${base} --size ${size} ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 2)
    message(FATAL_ERROR "'${ARGN}': expected exit 2, got ${rc}\nstderr: ${err}")
  endif()
  if(NOT err MATCHES "${flag}")
    message(FATAL_ERROR "'${ARGN}': the message does not name ${flag}: ${err}")
  endif()
  string(STRIP "${err}" stripped)
  if(stripped MATCHES "\n")
    message(FATAL_ERROR "'${ARGN}': expected one line on stderr, got:\n${err}")
  endif()
  if(EXISTS ${WORK_DIR}/out.png)
    message(FATAL_ERROR "'${ARGN}': an output was written")
  endif()
endfunction()

expect_usage_error(--spp 16x12 --spp 3)
expect_usage_error(--spp 16x12 --spp 0)
expect_usage_error(--spp 16x12 --spp 81)
expect_usage_error(--spp 16x12 --spp -4)
expect_usage_error(--spp 16x12 --spp many)
expect_usage_error(--spp 4000x10 --mode exact --spp 25)
expect_usage_error(--path-rule 16x12 --mode exact --path-rule sideways)
expect_usage_error(--path-rule 16x12 --mode single-interface --path-rule first-refraction)
expect_usage_error("--dev throughput" 16x12 --mode full-tree --dev throughput)
expect_usage_error("--dev filtered" 16x12 --mode single-interface --dev filtered)
expect_usage_error("--dev env-taps" 16x12 --dev env-taps=0)
expect_usage_error("--dev env-taps" 16x12 --dev env-taps=5)
expect_usage_error("--dev env-taps" 16x12 --dev env-taps=two)
expect_usage_error("--dev env-taps" 16x12 --mode exact --dev env-taps=1)
expect_usage_error("--dev env-level-bias" 16x12 --mode exact --dev filtered --dev env-level-bias=5)
expect_usage_error("--dev env-level-bias" 16x12 --mode exact --dev filtered --dev env-level-bias=-4.5)
expect_usage_error("--dev env-level-bias" 16x12 --mode exact --dev filtered --dev env-level-bias=nan)
expect_usage_error("--dev env-level-bias" 16x12 --mode exact --dev env-level-bias=-1)
expect_usage_error("--dev env-level-bias" 16x12 --dev env-level-bias=-1)
expect_usage_error(--volume-per-fragment 16x12 --volume-per-fragment)
expect_usage_error(--volume-per-fragment 16x12 --mode exact --volume-per-fragment)
expect_usage_error("--dev no-volume-refine" 16x12 --dev no-volume-refine)
expect_usage_error("--dev no-volume-refine" 16x12 --mode full-tree --dev no-volume-refine)
expect_usage_error("--dev no-refine" 16x12 --dev no-refine)
expect_usage_error("--dev no-refine" 16x12 --mode exact --dev filtered --dev no-refine)
expect_usage_error("--dev no-refine" 16x12 --mode full-tree --dev no-refine)
# The former spellings of the options still parse (unlisted), their errors naming them as given.
expect_usage_error(--env-taps 16x12 --env-taps 5)
expect_usage_error(--msaa 16x12 --msaa 3)
expect_usage_error(--msaa 16x12 --msaa 0)
expect_usage_error(--msaa 16x12 --msaa 16)
expect_usage_error(--msaa 16x12 --msaa four)
expect_usage_error(--msaa 16x12 --mode exact --msaa 4)
expect_usage_error(--msaa 16x12 --mode full-tree --msaa 4)

# CPU modes: always available.
execute_process(COMMAND ${SHREFRACT} ${base} --size 16x12 --mode exact --spp 4 --path-rule first-refraction --dev throughput
                        --dev filtered --dev env-taps=1 --dev env-level-bias=-0.5 --json
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT EXISTS ${WORK_DIR}/out.png)
  message(FATAL_ERROR "exact render with --spp 4 failed (${rc}): ${err}")
endif()
foreach(field "\"spp\": 4" "\"path_rule\": \"first-refraction\"" "\"throughput\": true" "\"filtered\": true" "\"env_taps\": 1"
              "\"env_level_bias\": -0.5")
  if(NOT out MATCHES "${field}")
    message(FATAL_ERROR "the JSON summary lacks ${field}: ${out}")
  endif()
endforeach()
file(REMOVE ${WORK_DIR}/out.png)
execute_process(COMMAND ${SHREFRACT} ${base} --size 16x12 --mode full-tree --dev tree-depth=3 --spp 9 --dev filtered
                RESULT_VARIABLE rc ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "full-tree render with --spp 9 failed (${rc}): ${err}")
endif()
file(REMOVE ${WORK_DIR}/out.png)
# The full tree's refinement: on by default (the sphere's rim is refined), off with --dev no-refine.
foreach(flag "" "--dev;no-refine")
  execute_process(COMMAND ${SHREFRACT} ${base} --size 32x24 --mode full-tree --dev tree-depth=3 --dev filtered ${flag} --json
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(flag)
    set(want "\"refined\": 0,")
  else()
    set(want "\"refined\": [1-9][0-9]*,")
  endif()
  if(NOT rc EQUAL 0 OR NOT out MATCHES "${want}")
    message(FATAL_ERROR "full-tree --dev filtered ${flag}: expected ${want} (${rc}): ${err}${out}")
  endif()
  file(REMOVE ${WORK_DIR}/out.png)
endforeach()

# A field's exact render follows the rule the field was baked with (the tool's default bake:
# first-refraction) unless --path-rule says otherwise. Planted once: render's default rule kept
# for fields (highest-energy) fails the first check.
execute_process(COMMAND ${SHREFRACT} bake builtin:sphere --tessellation 1 --samples 200 --encoding sh --order 2
                        --dev directions=8x16 -o ${WORK_DIR}/tiny.shrf --json
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT out MATCHES "\"path_rule\": \"first-refraction\"")
  message(FATAL_ERROR "the default bake is not first-refraction (${rc}): ${err}${out}")
endif()
foreach(rule "" highest-energy)
  set(flags)
  set(expect first-refraction)
  if(rule)
    set(flags --path-rule ${rule})
    set(expect ${rule})
  endif()
  execute_process(COMMAND ${SHREFRACT} render ${WORK_DIR}/tiny.shrf --mode exact --size 16x12 ${flags} --json
                          -o ${WORK_DIR}/out.png
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0 OR NOT out MATCHES "\"path_rule\": \"${expect}\"")
    message(FATAL_ERROR "exact render of a first-refraction field with '${flags}': expected ${expect} (${rc}): ${err}${out}")
  endif()
  file(REMOVE ${WORK_DIR}/out.png)
endforeach()
# The volume flags on a field of another encoding (found once the field is read): exit 2 naming
# the flag, nothing written; without --volume-per-fragment, --dev no-volume-refine is refused
# before reading.
foreach(flags "--volume-per-fragment" "--dev;no-volume-refine" "--volume-per-fragment;--dev;no-volume-refine")
  execute_process(COMMAND ${SHREFRACT} render ${WORK_DIR}/tiny.shrf --size 16x12 ${flags} -o ${WORK_DIR}/out.png
                  RESULT_VARIABLE rc ERROR_VARIABLE err)
  list(GET flags 0 named)
  if(named STREQUAL "--dev")
    set(named "--dev no-volume-refine")
  endif()
  if(NOT rc EQUAL 2 OR NOT err MATCHES "${named}" OR EXISTS ${WORK_DIR}/out.png)
    message(FATAL_ERROR "render of an SH field with '${flags}': expected exit 2 naming ${named} (${rc}): ${err}")
  endif()
endforeach()

# A GPU mode.
execute_process(COMMAND ${SHREFRACT} ${base} --size 16x12 --spp 16 --dev env-taps=3 --json RESULT_VARIABLE rc OUTPUT_VARIABLE out
                ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  if(rc EQUAL 3)  # the tool's exit status for "no Vulkan device" (samples/cli/commands.h)
    if(REQUIRE_GPU)
      message(FATAL_ERROR "no Vulkan device, and SHREFRACT_REQUIRE_GPU is on: ${err}")
    endif()
    message("SKIPPED: no Vulkan device: ${err}")
    return()
  endif()
  message(FATAL_ERROR "single-interface render with --spp 16 failed (${rc}): ${err}")
endif()
foreach(field "\"spp\": 16" "\"env_taps\": 3" "\"msaa\": 1" "\"volume_refine\": true")
  if(NOT out MATCHES "${field}")
    message(FATAL_ERROR "the JSON summary lacks ${field}: ${out}")
  endif()
endforeach()
file(REMOVE ${WORK_DIR}/out.png)
# 4 samples: every Vulkan device offers them for colour and depth.
execute_process(COMMAND ${SHREFRACT} ${base} --size 16x12 --msaa 4 --json RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0 OR NOT EXISTS ${WORK_DIR}/out.png OR NOT out MATCHES "\"msaa\": 4")
  message(FATAL_ERROR "render with --msaa 4 failed (${rc}): ${err}${out}")
endif()
file(REMOVE ${WORK_DIR}/out.png)
# 8: offered by some devices (not lavapipe): it renders, or it is refused as a usage error naming
# the flag with nothing written.
execute_process(COMMAND ${SHREFRACT} ${base} --size 16x12 --msaa 8 RESULT_VARIABLE rc ERROR_VARIABLE err)
if(rc EQUAL 2)
  if(NOT err MATCHES "--msaa 8" OR EXISTS ${WORK_DIR}/out.png)
    message(FATAL_ERROR "--msaa 8 refused without naming the flag, or with an output written: ${err}")
  endif()
elseif(NOT rc EQUAL 0)
  message(FATAL_ERROR "render with --msaa 8 failed (${rc}): ${err}")
endif()
message("render flags ok")
