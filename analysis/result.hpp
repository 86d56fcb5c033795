#pragma once
// Errors a user can cause (bad file, wrong value, missing device, timeout) are
// values, not exceptions: a Result<T> holds either the value or an Error whose
// message says what went wrong and what to do. Exceptions are for bugs only and
// never cross a library boundary.
#include <string>
#include <utility>
#include <variant>

namespace collide {

struct Error {
  std::string message;  ///< one line for the user: what, where (file/field/device), what to do
};

template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : v_(std::move(value)) {}      // NOLINT: implicit by design
  Result(Error error) : v_(std::move(error)) {}  // NOLINT: implicit by design

  bool ok() const { return std::holds_alternative<T>(v_); }
  explicit operator bool() const { return ok(); }

  T& value() & { return std::get<T>(v_); }
  const T& value() const& { return std::get<T>(v_); }
  T&& value() && { return std::get<T>(std::move(v_)); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() & { return value(); }
  const T& operator*() const& { return value(); }

  const Error& error() const { return std::get<Error>(v_); }

 private:
  std::variant<T, Error> v_;
};

/// Result of an operation that returns nothing but may fail.
struct Ok {};
using Status = Result<Ok>;

inline Error fail(std::string message) {
  return Error{std::move(message)};
}

}  // namespace collide
