# Warnings for shrefract's own targets only. Applied PRIVATE so they never leak to consumers.
function(shrefract_warnings target)
  target_compile_options(${target} PRIVATE
    $<$<COMPILE_LANGUAGE:CXX>:-Wall -Wextra -Wpedantic -Wshadow -Wconversion -Wno-sign-conversion
      -Wnon-virtual-dtor -Wold-style-cast -Wnull-dereference -Wdouble-promotion -Wformat=2
      # `VkFooInfo info{VK_STRUCTURE_TYPE_FOO}` zero-fills the rest on purpose: the Vulkan idiom.
      -Wno-missing-field-initializers>)
  if(SHREFRACT_WERROR)
    target_compile_options(${target} PRIVATE $<$<COMPILE_LANGUAGE:CXX>:-Werror>)
  endif()
endfunction()
