#include <shrefract/result.h>

namespace shrefract {

const char* toString(ErrorCode code) {
  switch (code) {
    case ErrorCode::InvalidArgument: return "invalid argument";
    case ErrorCode::Vulkan: return "Vulkan error";
    case ErrorCode::MissingFeature: return "missing device feature";
    case ErrorCode::Io: return "I/O error";
    case ErrorCode::CorruptData: return "corrupt data";
    case ErrorCode::Unsupported: return "unsupported";
    case ErrorCode::NoDevice: return "no Vulkan device";
  }
  return "unknown error";
}

}  // namespace shrefract
