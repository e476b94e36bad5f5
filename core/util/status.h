// Status and Result: errors as values at module boundaries.
//
// Every function that can fail on user input (files, scenes, settings) returns a Status or a
// Result<T>. The message names the problem precisely: the file, the line or element, the value.
// Nothing in core/ throws across a module boundary.
#pragma once

#include <optional>
#include <string>
#include <utility>

namespace kgd {

class Status {
 public:
  static Status Ok() { return Status(); }
  static Status Error(std::string message) { return Status(std::move(message)); }

  bool ok() const { return !message_.has_value(); }
  // The error message; empty when ok().
  const std::string& message() const {
    static const std::string kEmpty;
    return message_ ? *message_ : kEmpty;
  }
  // Prefixes the message with context ("scene.json: "), keeping ok() statuses unchanged.
  Status WithContext(const std::string& context) const {
    return ok() ? *this : Error(context + message());
  }

 private:
  Status() = default;
  explicit Status(std::string message) : message_(std::move(message)) {}
  std::optional<std::string> message_;
};

template <typename T>
class Result {
 public:
  Result(T value) : value_(std::move(value)), status_(Status::Ok()) {}  // NOLINT: implicit by design
  Result(Status status) : status_(std::move(status)) {}                 // NOLINT: implicit by design

  bool ok() const { return status_.ok(); }
  const Status& status() const { return status_; }
  const std::string& message() const { return status_.message(); }
  // Preconditions: ok().
  T& value() & { return *value_; }
  const T& value() const& { return *value_; }
  T&& value() && { return std::move(*value_); }
  T* operator->() { return &*value_; }
  const T* operator->() const { return &*value_; }
  T& operator*() { return *value_; }
  const T& operator*() const { return *value_; }

 private:
  std::optional<T> value_;
  Status status_;
};

}  // namespace kgd

// Returns the Status of `expr` from the enclosing function when it is an error.
#define KGD_RETURN_IF_ERROR(expr)                         \
  do {                                                    \
    if (::kgd::Status _s = (expr); !_s.ok()) return _s;   \
  } while (0)
