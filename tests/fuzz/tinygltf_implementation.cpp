// tinygltf's implementation for the fuzz build (the main build links Debian's libtinygltf).
#define TINYGLTF_IMPLEMENTATION
#include <tiny_gltf.h>
