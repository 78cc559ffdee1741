// Compiles and links against the installed shrefract::engine without any other dependency than the
// Vulkan headers: checks the public headers are self-contained and the library links.
#include <shrefract/context.h>
#include <shrefract/renderer.h>
#include <shrefract/sh.h>

#include <cmath>
#include <cstdio>

int main() {
  const shrefract::DeviceRequirements req = shrefract::deviceRequirements();
  float y[9];
  shrefract::sh::evaluate(2, 0.0f, 0.0f, 1.0f, y);
  // Y_0^0 = 1 / (2 sqrt(pi)); Y_1^0 at the pole = sqrt(3 / (4 pi)).
  const bool ok = std::fabs(y[0] - 0.2820948f) < 1e-5f && std::fabs(y[2] - 0.4886025f) < 1e-5f &&
                  req.apiVersion >= VK_API_VERSION_1_3;
  // Creating a context without handles must fail with an error value, not crash.
  auto context = shrefract::Context::create(shrefract::ContextCreateInfo{});
  if (context.ok()) return 1;
  std::printf("consumer: sh ok=%d, context error: %s\n", ok ? 1 : 0, context.error().message.c_str());
  return ok ? 0 : 1;
}
