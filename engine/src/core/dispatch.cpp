#include "core/dispatch.h"

namespace shrefract {

const char* Dispatch::load(PFN_vkGetInstanceProcAddr gipa, VkInstance instance, VkDevice device) {
#define SHREFRACT_LOAD_INSTANCE(name)                                                 \
  name = reinterpret_cast<PFN_##name>(gipa(instance, #name));                         \
  if (!name) return #name;
  SHREFRACT_INSTANCE_FUNCTIONS(SHREFRACT_LOAD_INSTANCE)
#undef SHREFRACT_LOAD_INSTANCE
#define SHREFRACT_LOAD_DEVICE(name)                                                   \
  name = reinterpret_cast<PFN_##name>(vkGetDeviceProcAddr(device, #name));           \
  if (!name) return #name;
  SHREFRACT_DEVICE_FUNCTIONS(SHREFRACT_LOAD_DEVICE)
#undef SHREFRACT_LOAD_DEVICE
  return nullptr;
}

}  // namespace shrefract
