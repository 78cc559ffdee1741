# The engine benchmarks must run on a GPU machine that has a Vulkan driver and nothing of the bake
#: fails when ldd lists an OpenImageIO or Embree library for any of BINARIES (a
# ;-separated list), or when ldd cannot read one. Run as
#   cmake -DBINARIES="a;b;c" -P portable_link_test.cmake
if(NOT BINARIES)
  message(FATAL_ERROR "BINARIES not set")
endif()
find_program(LDD ldd REQUIRED)
set(bad "")
foreach(binary IN LISTS BINARIES)
  execute_process(COMMAND ${LDD} ${binary} OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "ldd ${binary} failed (${rc}): ${err}")
  endif()
  string(REGEX MATCHALL "lib(OpenImageIO|embree)[^ \t\n]*" found "${out}")
  list(REMOVE_DUPLICATES found)  # ldd names each library twice: "libX.so => /path/libX.so"
  string(REGEX MATCHALL "\n" lines "${out}")
  list(LENGTH lines count)
  if(found)
    list(APPEND bad "${binary}: ${found}")
  else()
    message(STATUS "${binary}: ${count} shared libraries, none from OpenImageIO or Embree")
  endif()
endforeach()
if(bad)
  message(FATAL_ERROR "linked to the bake's libraries:\n${bad}")
endif()
