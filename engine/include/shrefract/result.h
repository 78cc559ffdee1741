// Errors are values: every fallible shrefract call returns Result<T>, which holds either the value
// or an Error (code, VkResult where one applies, and a one-line message). No exceptions cross the API.
#pragma once

#include <vulkan/vulkan_core.h>

#include <string>
#include <utility>
#include <variant>

namespace shrefract {

enum class ErrorCode {
  InvalidArgument,  // the caller passed something the contract forbids
  Vulkan,           // a Vulkan call failed; Error::vkResult holds its result
  MissingFeature,   // the device lacks a feature or extension shrefract needs
  Io,               // a file could not be opened, read or written
  CorruptData,      // a file or buffer failed validation (truncated, bad checksum, bad values)
  Unsupported,      // valid input that this version cannot handle (newer file version, format)
  NoDevice,         // no Vulkan driver or no suitable device (the headless harness: nothing to run on)
};

const char* toString(ErrorCode code);

struct Error {
  ErrorCode code = ErrorCode::InvalidArgument;
  std::string message;
  VkResult vkResult = VK_SUCCESS;
};

inline Error makeError(ErrorCode code, std::string message, VkResult vkResult = VK_SUCCESS) {
  return Error{code, std::move(message), vkResult};
}

template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : state_(std::in_place_index<0>, std::move(value)) {}
  Result(Error error) : state_(std::in_place_index<1>, std::move(error)) {}

  bool ok() const { return state_.index() == 0; }
  explicit operator bool() const { return ok(); }

  // Precondition for value(): ok(). For error(): !ok().
  T& value() & { return std::get<0>(state_); }
  const T& value() const& { return std::get<0>(state_); }
  T&& value() && { return std::get<0>(std::move(state_)); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }
  const Error& error() const { return std::get<1>(state_); }

 private:
  std::variant<T, Error> state_;
};

template <>
class [[nodiscard]] Result<void> {
 public:
  Result() = default;
  Result(Error error) : error_(std::move(error)), ok_(false) {}
  bool ok() const { return ok_; }
  explicit operator bool() const { return ok_; }
  const Error& error() const { return error_; }

 private:
  Error error_{};
  bool ok_ = true;
};

}  // namespace shrefract
