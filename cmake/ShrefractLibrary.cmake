# shrefract_library(NAME [INCLUDE DIR] SOURCES ... PUBLIC ... PRIVATE ...): the static library
# shrefract_NAME (alias shrefract::NAME) of the calling folder, with its public headers in DIR
# (default include) and its private ones in src, linked as given, with shrefract's warnings.
function(shrefract_library name)
  cmake_parse_arguments(ARG "" "INCLUDE" "SOURCES;PUBLIC;PRIVATE" ${ARGN})
  if(NOT ARG_INCLUDE)
    set(ARG_INCLUDE include)
  endif()
  add_library(shrefract_${name} STATIC ${ARG_SOURCES})
  add_library(shrefract::${name} ALIAS shrefract_${name})
  set_target_properties(shrefract_${name} PROPERTIES EXPORT_NAME ${name} OUTPUT_NAME shrefract_${name})
  target_include_directories(shrefract_${name}
    PUBLIC $<BUILD_INTERFACE:${CMAKE_CURRENT_SOURCE_DIR}/${ARG_INCLUDE}> $<INSTALL_INTERFACE:${CMAKE_INSTALL_INCLUDEDIR}>
    PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
  target_link_libraries(shrefract_${name} PUBLIC ${ARG_PUBLIC} PRIVATE ${ARG_PRIVATE})
  shrefract_warnings(shrefract_${name})
endfunction()
