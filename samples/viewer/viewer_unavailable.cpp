// Built when GLFW 3.3 was not found at configure time: `shrefract view` says so instead of failing
// to link. Debian: libglfw3-dev (scripts/setup-debian.sh installs it).
#include <cstdio>

#include "viewer/viewer.h"

namespace shrefract::viewer {

int runViewer(const ViewerOptions&) {
  std::fprintf(stderr, "shrefract view: this build has no viewer (GLFW 3.3 was not found; Debian: libglfw3-dev)\n");
  return 1;
}

}  // namespace shrefract::viewer
