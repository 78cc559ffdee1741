// Object::createFromFieldFile, in its own translation unit so that hosts that never read files
// do not link the file reader.
#include <shrefract/field.h>
#include <shrefract/renderer.h>

namespace shrefract {

Result<std::unique_ptr<Object>> Object::createFromFieldFile(Context& context, const std::string& path,
                                                            VkCommandBuffer cmd) {
  auto field = readField(path);
  if (!field) return field.error();
  auto object = createFromField(context, field.value(), cmd);
  if (!object) return makeError(object.error().code, path + ": " + object.error().message, object.error().vkResult);
  return object;
}

}  // namespace shrefract
